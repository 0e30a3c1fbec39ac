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
"""

from __future__ import annotations

import collections
import json
import os

#: per worker process: serialised run config -> Simulation
_SIMULATIONS: dict[str, object] = {}


def _execute_remote(config_json: str, threads: int, unit):
    """Run one work unit on a worker (module level, so Dask can pickle it by name)."""
    simulation = _SIMULATIONS.get(config_json)
    if simulation is None:
        from vcavity import config as config_mod
        from vcavity.simulate.pipeline import Simulation

        raw = json.loads(config_json)
        simulation = Simulation(config_mod.validate(raw, source="<dask worker>"), threads=threads)
        simulation.compile()
        _SIMULATIONS.clear()  # one run at a time per worker: free the previous kernel's state
        _SIMULATIONS[config_json] = simulation
    return simulation.execute(unit)


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
        Numba threads a unit uses on its worker (default 1: one unit per core).
    in_flight : int, optional
        Units submitted ahead of the one being merged (default 4 per worker thread).

    Raises
    ------
    ImportError
        ``dask.distributed`` is not installed (``pip install 'vcavity[distributed]'``).
    """

    def __init__(self, address: str, threads_per_task: int = 1, in_flight: int | None = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - depends on the installation
            raise ImportError("--dask needs dask.distributed: pip install 'vcavity[distributed]'") from exc
        where, n_workers = parse_address(address)
        self.cluster = None
        if where == "local":
            self.cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                        dashboard_address=None, env={"NUMBA_NUM_THREADS": str(threads_per_task)})
            self.client = Client(self.cluster)
        else:
            self.client = Client(where)
        self.threads_per_task = int(threads_per_task)
        workers = max(1, sum(self.client.nthreads().values()))
        self.in_flight = int(in_flight) if in_flight else 4 * workers

    def __call__(self, simulation, units):
        """``(unit, simulation.execute(unit))`` for each unit, in order (a generator).

        Units are drawn from ``units`` lazily, at most ``in_flight`` ahead of the one
        being merged, so a direction of 2^62 paths never materialises its unit list.
        """
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
                yield unit, future.result()
        finally:  # a stop between units: cancel what is still queued or running
            pending = [f for _, f in window if not f.done()]
            if pending:
                self.client.cancel(pending)

    def worker_pids(self) -> dict:
        """Worker address -> process id (for tests and diagnostics)."""
        return self.client.run(os.getpid)

    def close(self) -> None:
        """Shut the client (and a local cluster) down."""
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
