"""Work units on a Dask cluster (the optional extra ``vcavity[distributed]``; docs/distributed.md).

A run is cut into work units (an incident direction, a first block, a number of blocks:
:class:`vcavity.simulate.pipeline.WorkUnit`); each unit is a pure function of the configuration,
the seed and its blocks, returning integer tallies. :class:`DaskExecutor` sends units to
Dask workers as tasks and hands their results back **in the order of the units**, so
the client merges them exactly as a local run does: the table is bitwise identical to a
local run's, whatever the number of workers, and a task lost with a killed worker is
simply computed again (Dask reschedules it; ``retries`` covers errors on the way).

Each worker process builds the :class:`~vcavity.simulate.pipeline.Simulation` of a configuration
once (its kernel compiled or loaded from the worker's Numba cache) and keeps it for the
next units of the same run.

Interrupts and shutdown: the worker processes of ``local:N`` start with SIGINT and
SIGTERM blocked (:func:`_signals_blocked`), so a Ctrl-C in a terminal, which reaches
the whole process group, stops only this process, which saves its checkpoint and shuts
the cluster down itself (its nanny ends each worker with a stop message, else SIGKILL);
and while the executor cancels tasks and shuts down, Dask's loggers here and in the
local workers are quiet (:func:`quiet_logs`): a worker whose task is cancelled, a
scheduler losing a worker it closes, are not news to the user.
"""

from __future__ import annotations

import collections
import contextlib
import json
import logging
import os
import signal
import threading
import time

#: Seconds of work a task aims at (docs/distributed.md, "How a run is cut").
TASK_TARGET_S = 1.0

#: per worker process: serialised run config -> Simulation
_SIMULATIONS: dict[str, object] = {}


def _execute_remote(config_json: str, threads: int, unit):
    """Run one work unit on a worker (module level, so Dask can pickle it by name);
    returns its outcome and the seconds it took (which size the next units)."""
    simulation = _SIMULATIONS.get(config_json)
    if simulation is None:
        from vcavity import config as config_mod
        from vcavity.simulate.pipeline import Simulation

        raw = json.loads(config_json)
        simulation = Simulation(config_mod.validate(raw, source="<dask worker>"), threads=threads)
        simulation.compile()
        _SIMULATIONS.clear()  # one run at a time per worker: free the previous kernel's state
        _SIMULATIONS[config_json] = simulation
    t0 = time.perf_counter()
    outcome = simulation.execute(unit)
    return outcome, time.perf_counter() - t0


def _cuda_status(needed_bytes: int) -> dict:
    """On a worker: ``{"attributes": ...}`` of the GPU it would run the walk on (the table's
    device attributes), or ``{"error": why it cannot}`` (module level, for ``client.run``)."""
    try:
        from vcavity.kernels.walks import cuda_unavailable  # (plan's: plan imports this module)

        reason = cuda_unavailable()
        if reason is not None:
            return {"error": reason}
        from vcavity.kernels import cuda_loop

        attributes = cuda_loop.device_attributes()
        free = cuda_loop.free_memory()
    except Exception as exc:  # noqa: BLE001 - whatever stops it is the worker's answer
        return {"error": f"{type(exc).__name__}: {(str(exc).splitlines() or [''])[0]}"}
    if free is not None and needed_bytes > free:
        return {"error": f"the GPU's tally needs about {needed_bytes / 2**20:,.2f} MiB, {free / 2**20:,.2f} MiB "
                         f"free on {attributes['device_name']}"}
    return {"attributes": attributes}


def _local_gpus() -> list[str] | None:
    """The GPUs of this machine a local cluster gives its workers, one each (their
    ``CUDA_VISIBLE_DEVICES`` values), or None: none found, or numba's simulator (the
    workers' check then says why)."""
    try:
        from vcavity.kernels import cuda_loop
    except ImportError:
        return None
    if cuda_loop.SIMULATED or not cuda_loop.cuda.is_available():
        return None
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    devices = ([d.strip() for d in visible.split(",") if d.strip()] if visible is not None
               else [str(k) for k in range(len(cuda_loop.cuda.gpus))])
    return devices or None


def _gpu_cluster(devices, **options):
    """A ``distributed.LocalCluster`` of one single-threaded worker process per GPU in
    ``devices``, each seeing its own (``CUDA_VISIBLE_DEVICES``), as dask-cuda's
    ``LocalCUDACluster`` starts them."""
    import copy

    from distributed import LocalCluster

    class OneWorkerPerGpu(LocalCluster):
        def new_worker_spec(self):
            used = {spec["options"]["env"]["CUDA_VISIBLE_DEVICES"] for spec in self.worker_spec.values()}
            device = next(d for d in devices if d not in used)
            spec = copy.deepcopy(self.new_spec)
            spec["options"]["env"] = {**spec["options"].get("env", {}), "CUDA_VISIBLE_DEVICES": device}
            return {f"gpu-{device}": spec}

    cluster = OneWorkerPerGpu(n_workers=0, **options)
    cluster.scale(len(devices))
    return cluster


#: the loggers quieted while an executor shuts down (a prefix of the logger's name)
_NOISY_LOGGERS = ("distributed", "tornado", "asyncio")


@contextlib.contextmanager
def quiet_logs():
    """Dask's loggers in this process say nothing inside the block (restored after it).

    Each existing logger named ``distributed...`` (and tornado's, asyncio's) is disabled:
    a disabled logger drops the records logged to it before any handler or propagation
    sees them, whatever logging the user configured; loggers outside these names, and
    these ones after the block, are untouched.
    """
    manager = logging.Logger.manager
    loggers = [logging.getLogger(name) for name in list(manager.loggerDict)
               if name.split(".", 1)[0] in _NOISY_LOGGERS]
    loggers += [logging.getLogger(name) for name in _NOISY_LOGGERS]
    previous = [(logger, logger.disabled) for logger in loggers]
    for logger in loggers:
        logger.disabled = True
    try:
        yield
    finally:
        for logger, disabled in previous:
            logger.disabled = disabled


def _quiet_worker() -> None:
    """On a local worker about to be cancelled and closed: its Dask loggers say nothing
    more (run by ``client.run``; the process ends with the cluster, nothing to restore)."""
    for name in list(logging.Logger.manager.loggerDict) + list(_NOISY_LOGGERS):
        if name.split(".", 1)[0] in _NOISY_LOGGERS:
            logging.getLogger(name).disabled = True


@contextlib.contextmanager
def _signals_blocked():
    """SIGINT and SIGTERM blocked in this thread inside the block (main thread only).

    Threads started meanwhile (the local cluster's event loop, its process watchers)
    inherit the blocked mask, and so do the worker processes they spawn, then or later
    (a blocked signal stays blocked across fork and exec): a Ctrl-C to the process group
    reaches this process only. A signal that arrives inside the block is not lost: it is
    delivered when the block ends.
    """
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # multiprocessing's resource tracker, when it starts, unblocks SIGINT and SIGTERM in
    # the thread that starts it (it blocks them around its own spawn, then unblocks, not
    # restores): started here first, it is not started again by the cluster's event loop
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _cores() -> int:
    """Cores this process may run on (its CPU affinity where the system has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def parse_address(text: str) -> tuple[str, int | None]:
    """``local:N`` -> ("local", N); a scheduler address -> (text, None).

    A scheduler address is ``PROTOCOL://HOST:PORT`` or ``HOST:PORT`` (as Dask's ``Client``
    takes it); whether a scheduler answers there is known only when connecting.

    Raises
    ------
    ValueError
        One line, without the ``--dask = ...`` prefix the caller adds: an empty address,
        one that is no address, or ``local:N`` without N in 1 .. the cores here (each of the
        N workers is a process: more than the cores only compete for them).
    """
    if not text:
        raise ValueError("give a scheduler address (tcp://host:8786) or local:N")
    if text.startswith("local:"):
        count, cores = text[len("local:"):], _cores()
        if not count.isdigit() or not 1 <= int(count) <= cores:
            raise ValueError(f"local:N starts N worker processes: N must be an integer from 1 to {cores} "
                             f"(the cores here)")
        return "local", int(count)
    host = text.split("://", 1)[1] if "://" in text else text
    if not host or ":" not in host or not host.rsplit(":", 1)[1].isdigit() or any(c.isspace() for c in text):
        raise ValueError("not a scheduler address: give PROTOCOL://HOST:PORT (tcp://host:8786), HOST:PORT "
                         "or local:N")
    return text, None


class DaskExecutor:
    """Execute work units as Dask tasks (see module doc).

    Parameters
    ----------
    address : str
        A scheduler address (``tcp://host:8786``) or ``local:N`` for a
        ``distributed.LocalCluster`` of N single-threaded worker processes.
    threads_per_task : int
        Threads a unit uses on its worker: kernel slots, and the models' Numba threads
        (default 1: one unit per core).
    in_flight : int, optional
        Units submitted ahead of the one being merged (default 4 per worker thread).
    device : str
        ``simulation.device`` of the runs: on ``"cuda"``, ``local:N`` starts one worker per
        GPU of this machine (N at most their number; under numba's simulator, N workers).

    Attributes
    ----------
    device_attributes : dict or None
        What the tables record of the workers' GPUs (:meth:`check_cuda`); None: the walk's
        device is this process's (a CPU run).

    Raises
    ------
    ImportError
        ``dask.distributed`` is not installed (``pip install 'vcavity[distributed]'``).
    ValueError
        ``local:N`` on ``"cuda"`` with more workers than GPUs here (one line).
    """

    def __init__(self, address: str, threads_per_task: int = 1, in_flight: int | None = None,
                 device: str = "cpu"):
        try:
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError("--dask needs dask.distributed: pip install 'vcavity[distributed]'") from exc
        from vcavity.simulate.interrupts import DeferredInterrupt

        where, n_workers = parse_address(address)
        self.cluster = self.client = None
        self.device_attributes = None
        gpus = _local_gpus() if where == "local" and device == "cuda" else None
        if gpus is not None and n_workers > len(gpus):
            raise ValueError(f"with simulation.device = 'cuda', local:N starts one worker per GPU: N must be from 1 "
                             f"to {len(gpus)} (the GPUs here)")
        if where == "local":
            # a Ctrl-C while the cluster starts waits for it (seconds), then closes it again:
            # a cluster left half started would leave its processes and semaphores behind
            with DeferredInterrupt() as interrupt:
                try:
                    with _signals_blocked():
                        # no dashboard; the scheduler's HTTP server (health, metrics) still
                        # starts, by default on port 8787: on a free local port instead, so two
                        # runs at once do not print distributed's "Port 8787 is already in use"
                        options = dict(threads_per_worker=1, processes=True, dashboard_address=None,
                                       scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                                       env={"NUMBA_NUM_THREADS": str(threads_per_task)})
                        self.cluster = (LocalCluster(n_workers=n_workers, **options) if gpus is None
                                        else _gpu_cluster(gpus[:n_workers], **options))
                        self.client = Client(self.cluster)
                        self.client.wait_for_workers(n_workers)
                except BaseException:
                    self.close()
                    raise
            if interrupt.requested:
                self.close()
                raise KeyboardInterrupt
        else:
            self.client = Client(where)  # a Ctrl-C while connecting (up to 30 s) stops at once
        self.threads_per_task = int(threads_per_task)
        workers = max(1, sum(self.client.nthreads().values()))
        self.in_flight = int(in_flight) if in_flight else 4 * workers

    def __call__(self, simulation, units):
        """``(unit, simulation.execute(unit))`` for each unit, in order (a generator).

        Units are drawn from ``units`` lazily, at most ``in_flight`` ahead of the one
        being merged, so a direction of 2^62 paths never materialises its unit list.
        """
        # a task should take about a second on its worker: its overhead is milliseconds
        simulation.chunks.aim(TASK_TARGET_S)
        config = simulation.config.to_dict()
        raw = {key: config[key] for key in ("material", "incidence", "simulation")}
        config_json = json.dumps(raw, sort_keys=True)
        window = collections.deque()
        units = iter(units)
        try:
            while True:
                while len(window) < self.in_flight:
                    unit = next(units, None)
                    if unit is None:
                        break
                    window.append((unit, self.client.submit(_execute_remote, config_json, self.threads_per_task,
                                                            unit, pure=False, retries=3)))
                if not window:
                    return
                unit, future = window.popleft()
                outcome, seconds = future.result()
                simulation.chunks.observe(unit.n_blocks, seconds)
                yield unit, outcome
        finally:  # a stop between units: cancel what is still queued or running
            pending = [f for _, f in window if not f.done()]
            if pending:
                with quiet_logs():
                    self._quiet_workers()
                    self.client.cancel(pending)

    def check_cuda(self, needed_bytes: int = 0) -> None:
        """Ask every worker whether it can run the CUDA walk (numba-cuda, a GPU, its free
        memory for a launch's tally of ``needed_bytes``); keep what the tables record of
        their GPUs in :attr:`device_attributes` (each value the workers' distinct ones, joined
        by ``", "``).

        Raises
        ------
        ValueError
            One line: no worker is connected, or the first worker that cannot, and why.
        """
        answers = self.client.run(_cuda_status, int(needed_bytes))
        if not answers:
            raise ValueError("no Dask worker is connected to the scheduler")
        for worker, answer in sorted(answers.items()):
            if "error" in answer:
                raise ValueError(f"worker {worker} (of {len(answers)}): {answer['error']}")
        attributes = [answer["attributes"] for answer in answers.values()]
        self.device_attributes = {"device": "cuda", **{
            key: ", ".join(sorted({a[key] for a in attributes})) for key in attributes[0]}}

    def worker_pids(self) -> dict:
        """Worker address -> process id (for tests and diagnostics)."""
        return self.client.run(os.getpid)

    def _quiet_workers(self) -> None:
        """A local cluster's workers log nothing more (they write to this terminal);
        a remote cluster's workers log where their operator reads, and are left alone."""
        if self.cluster is not None and self.client is not None:
            with contextlib.suppress(Exception):  # a worker already gone has nothing to say
                self.client.run(_quiet_worker)

    def close(self) -> None:
        """Shut the client (and a local cluster) down, Dask's loggers quiet meanwhile.

        A Ctrl-C (or SIGTERM) meanwhile lets the shutdown finish and is then remembered as
        pending (:func:`vcavity.simulate.interrupts.raise_if_pending`), for the command to
        report with what it has written: the shutdown is never left half done.
        """
        from vcavity.simulate import interrupts

        with interrupts.DeferredInterrupt() as interrupt, quiet_logs():
            self._quiet_workers()
            if self.client is not None:
                self.client.close()
            if self.cluster is not None:
                self.cluster.close()
        if interrupt.requested:
            interrupts.remember()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
