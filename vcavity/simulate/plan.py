"""Planning a run: every check that can fail, before anything is compiled or traced.

A :class:`RunRequest` is what the user asked (the validated config and the command's
options); :func:`plan_run` checks it against the machine and the file system and returns
a :class:`RunPlan`, or raises :class:`PlanError` with one line naming the flag or field as
the user wrote it, the value and what is accepted: the output path (links, folders,
FIFOs, the config itself, an existing file without ``--overwrite``, a folder that does not
exist or takes no file), the output's writer lock (another run or sweep writing it:
:mod:`vcavity.io.lock`), the checkpoint (resumed, refused, or another run's), the threads,
the Dask address's form, the device (:func:`check_device`), the estimator's own refusals
(a model's table has nothing to distribute), the memory and the disk space. A
sweep makes the same checks of its points (:mod:`vcavity.sweep.run`, ``vcavity sweep``):
:func:`check_threads`, :func:`check_dask_address`, :func:`check_device`,
:func:`check_dask_work`.

The checks that touch files are io's (:mod:`vcavity.io.preflight`); this module knows
which to make and in what order. Nothing here compiles.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numba

from vcavity.config import RunConfig
from vcavity.estimators import registry as estimators
from vcavity.io import checkpoint, preflight
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate import state as run_state


class PlanError(ValueError):
    """A run cannot start (or could not finish); the message is the whole one-line error."""


@dataclass(frozen=True)
class RunRequest:
    """What the user asked of a run.

    Attributes
    ----------
    config : RunConfig
        The validated run (flags already applied).
    config_file : str or None
        The CONFIG argument as given (None: the built-in run): the output is named after it
        and is never it.
    output : str or None
        ``-o``; default ``[output].path``, else CONFIG with ``.h5``, else ``vcavity-default.h5``.
    overwrite, resume : bool
        Replace an existing output; continue the run of its checkpoint.
    threads, chunk_blocks : int or None
        Worker threads (default: all cores) and RNG blocks per walk call; neither changes the table.
    dask : str or None
        A Dask scheduler address, or ``local:N``.
    checkpoint_every_s : float
        Seconds between checkpoints.
    """

    config: RunConfig
    config_file: str | None = None
    output: str | None = None
    overwrite: bool = False
    resume: bool = False
    threads: int | None = None
    chunk_blocks: int | None = None
    dask: str | None = None
    checkpoint_every_s: float = 60.0


@dataclass(frozen=True)
class RunPlan:
    """A run that passed every check (:func:`plan_run`).

    Attributes
    ----------
    request : RunRequest
    config : RunConfig
        The request's config recording where the table goes (an absolute path).
    output : vcavity.io.preflight.Output
        The table's path and the flag or field that named it.
    threads : int
    state : RunState or None
        The resumed checkpoint's state (None: from the first path).
    removed : tuple of pathlib.Path
        Stale temporary files of interrupted writes, removed from the output's folder.
    resume_note : str or None
        What ``--resume`` found (no checkpoint yet, or how far the run got).
    lock_note : str or None
        The stale writer lock of a gone process that this run took over, if any.
    """

    request: RunRequest
    config: RunConfig
    output: preflight.Output
    threads: int
    state: run_state.RunState | None = None
    removed: tuple[Path, ...] = ()
    resume_note: str | None = None
    lock_note: str | None = None

    @property
    def traces(self) -> bool:
        """Whether the run traces paths (False: its estimator's models are the table)."""
        return estimators.get(self.config.estimator).walk(self.config.material) is not None

    @property
    def total_paths(self) -> int:
        """Paths planned: every direction's budget (0 when nothing is traced)."""
        return sum(self.config.path_budget(d) for d in self.config.incidence) if self.traces else 0


def check_threads(threads: int | None) -> int:
    """``--threads`` as a count, all cores by default.

    Raises
    ------
    PlanError
        More threads than cores.
    """
    cores = numba.config.NUMBA_NUM_THREADS
    if threads is not None and not 1 <= threads <= cores:
        raise PlanError(f"--threads = {threads}: must be between 1 and {cores} (cores here)")
    return threads or cores


def check_dask_address(address: str | None) -> None:
    """The form of ``--dask ADDRESS``, before anything compiles (connecting comes later).

    Raises
    ------
    PlanError
    """
    if address is None:
        return
    from vcavity.simulate.dask import parse_address

    try:
        parse_address(address)
    except ValueError as exc:
        raise PlanError(f"--dask = {address!r}: {exc}") from None


def cuda_unavailable() -> str | None:
    """Why this process cannot run CUDA kernels, or None when it can (a GPU and its driver,
    or numba's CUDA simulator, ``NUMBA_ENABLE_CUDASIM=1``).

    numba-cuda is imported here, when a run asks for it, never when vcavity is imported.

    Returns
    -------
    str or None
        One phrase: numba-cuda is not installed, or no CUDA device or driver is found.
    """
    from vcavity.kernels import walks

    return walks.cuda_unavailable()


def check_device(config: RunConfig, dask: str | None = None) -> None:
    """Whether the run's walk can run on ``config.device``, before anything compiles.

    The CPU always can. CUDA refuses, in this order: an estimator that traces no path, a
    weighted walk (the paper estimator's), numba-cuda not installed, and no CUDA device or
    driver (:func:`cuda_unavailable`). With ``--dask`` the walk runs on the workers' GPUs,
    not here: the last two are asked of every worker once connected
    (:func:`vcavity.simulate.service.check_workers`).

    Raises
    ------
    PlanError
        One line starting ``simulation.device = 'cuda':`` (the command names ``--device``
        instead when the flag gave the value).
    """
    if config.device == "cpu":
        return
    field = f"simulation.device = {config.device!r}"
    walk = estimators.get(config.estimator).walk(config.material)
    if walk is None:
        raise PlanError(f"{field}: the {config.estimator} estimator traces no path, there is nothing to run on "
                        "a GPU")
    from vcavity.kernels import registry as walks

    if walks.get(walk).WEIGHTED:
        unweighted = ", ".join(m.NAME for m in walks.MODULES if not m.WEIGHTED)
        raise PlanError(f"{field}: the {config.estimator} estimator runs on the CPU only: its walk is weighted "
                        f"(the GPU runs the unweighted walks: {unweighted})")
    if dask is not None:  # the workers' GPUs run the walk (asked once connected)
        return
    reason = cuda_unavailable()
    if reason is not None:
        raise PlanError(f"{field}: {reason}")


def check_device_memory(config: RunConfig, n_cells: int, dask: str | None = None) -> None:
    """On ``device = "cuda"`` here (not ``--dask``: each worker checks its own GPU), whether
    a launch's tally fits in the GPU's free memory (:func:`vcavity.kernels.cuda_loop.launch_bytes`);
    nothing to check under the simulator. Call after :func:`check_device`.

    Raises
    ------
    PlanError
        Naming ``simulation.sensor_resolution`` and ``max_order``, with the figures.
    """
    if config.device != "cuda" or dask is not None:
        return
    from vcavity.kernels import cuda_loop

    free = cuda_loop.free_memory()
    if free is None:  # the simulator: no device
        return
    needed = cuda_loop.launch_bytes(config.max_order, n_cells)
    if needed > free:
        name = cuda_loop.device_attributes()["device_name"]
        raise PlanError(f"simulation.sensor_resolution = {config.sensor_resolution} with max_order = "
                        f"{config.max_order}: the GPU's tally needs about {needed / 2**20:,.2f} MiB "
                        f"({config.max_order + 1} orders x {n_cells:,} cells), {free / 2**20:,.2f} MiB free on "
                        f"{name}; accepted: a run that fits (lower sensor_resolution or max_order)")


def check_dask_work(config: RunConfig, dask: str | None) -> None:
    """``--dask`` needs paths to distribute: an estimator that traces none is refused (one line).

    Raises
    ------
    PlanError
        ``--dask = '...': the exact estimator traces no path, there is nothing to distribute``.
    """
    if dask is not None and estimators.get(config.estimator).walk(config.material) is None:
        raise PlanError(f"--dask = {dask!r}: the {config.estimator} estimator traces no path, there is "
                        "nothing to distribute")


def plan_run(request: RunRequest, locks=None) -> RunPlan:
    """Every check of a run, in the order a user fixes them (module doc).

    With ``locks`` (a :class:`contextlib.ExitStack`) the output's writer lock
    (:mod:`vcavity.io.lock`: ``OUT.h5.lock``, covering the table and its checkpoint) is
    taken once the path is known to be a possible output, before the checkpoint is read,
    and held until ``locks`` closes: a second run or sweep writing the same file is refused.

    Raises
    ------
    PlanError
        The first check that failed, as its one-line error.
    """
    cfg = request.config
    try:
        out = preflight.resolve_output(request.output, cfg.output, request.config_file)
        preflight.check_output(out, request.config_file, True)  # links, folders, FIFOs, the config itself
        held = preflight.lock_output(out, locks) if locks is not None else None
        resuming = request.resume and checkpoint.checkpoint_path(out.path).exists()
        preflight.check_output(out, request.config_file, request.overwrite or resuming)  # and an existing table
        # without --overwrite, resume replaces only its own run's table (say, written just
        # before a kill that left the checkpoint): never what was put there meanwhile
        what = (checkpoint.foreign_output(out.path, cfg.to_dict()) if resuming and not request.overwrite
                and out.path.is_file() else None)
        if what is not None:
            raise out.fail(f"exists and is {what}; --resume replaces only the table of this run: "
                           "pass --overwrite to replace it")
        threads = check_threads(request.threads)
        check_dask_address(request.dask)
        check_device(cfg, request.dask)
        check_dask_work(cfg, request.dask)
        estimator = estimators.get(cfg.estimator)
        n_cells = EqualAreaSensor(cfg.sensor_resolution).n_cells
        preflight.check_memory(cfg, threads, n_cells, len(estimator.TALLIES))
        check_device_memory(cfg, n_cells, request.dask)
        removed = preflight.probe_output(out)  # creates and removes a file: /proc, /sys, read-only
        preflight.check_disk_space(out, preflight.table_bytes(len(cfg.incidence), len(cfg.orders), n_cells))
    except preflight.PreflightError as exc:
        raise PlanError(str(exc)) from None
    config = dataclasses.replace(cfg, output=out.path.resolve())  # the table records where it was written
    state, note = _start(request, config, out.path, n_cells)
    return RunPlan(request=request, config=config, output=out, threads=threads, state=state,
                   removed=tuple(removed), resume_note=note, lock_note=held.note() if held is not None else None)


def _start(request: RunRequest, config: RunConfig, output: Path, n_cells: int):
    """The state to start from and what to say of it: the checkpoint's with ``--resume``.

    Raises
    ------
    PlanError
        An unusable checkpoint with ``--resume``, or one of an unfinished run without it
        (``--overwrite`` starts afresh: the first save replaces it).
    """
    path = checkpoint.checkpoint_path(output)
    try:
        checkpoint.refuse_non_file(path)  # a folder there is neither resumed nor replaced
        if not request.resume:
            if path.exists() and not request.overwrite:
                raise checkpoint.CheckpointError(
                    f"checkpoint {str(path)!r} of an unfinished run exists: --resume to continue it, or "
                    "--overwrite to start afresh (it is then replaced)")
            return None, None
        if not path.exists():
            return None, f"--resume: no checkpoint {str(path)!r}; starting from the first path"
        state = run_state.load(path, config, layout=run_state.start(config, n_cells))
    except checkpoint.CheckpointError as exc:
        raise PlanError(str(exc)) from None
    planned = sum(config.path_budget(d) for d in config.incidence)
    return state, f"resuming from {path} ({int(state.paths_done(config).sum()):,} of {planned:,} paths done)"


__all__ = ["PlanError", "RunPlan", "RunRequest", "check_dask_address", "check_device", "check_device_memory",
           "check_threads", "cuda_unavailable", "plan_run"]
