"""A planned run carried out: compile, model, trace with checkpoints and Ctrl-C, write the table.

``vcavity run`` plans a run (:mod:`vcavity.simulate.plan`: every check before compiling),
then calls :func:`prepare` (the simulation, its walk compiled or loaded, its estimator's
models) and :func:`execute` (the paths traced, the table written), and prints what they
report. What the user sees is the caller's: the service says things through ``say(text)``
and reports progress through ``progress`` (:class:`Progress`), so the command decides how
they look.

It never loses finished work: the run's state is saved atomically to
``<OUT>.checkpoint`` every ``checkpoint_every_s`` seconds (:mod:`vcavity.simulate.state`),
Ctrl-C (SIGINT, and SIGTERM as it) is turned into a request to stop at the next chunk
boundary, which saves a checkpoint and returns None, and the checkpoint is removed only
once the table is written. ``--resume`` continues from the checkpoint; the final table is
bitwise identical to an uninterrupted run because the state is an integer tally of a
prefix of each direction's blocks and later blocks do not depend on earlier ones.
"""

from __future__ import annotations

from typing import Callable, Protocol

from vcavity.io import checkpoint
from vcavity.io.schema import TableValue
from vcavity.simulate import state as run_state
from vcavity.simulate.plan import PlanError, RunPlan


class Progress(Protocol):
    """What a run reports while it traces (a progress bar, or nothing)."""

    def advance(self, paths: int, error: float) -> None:
        """``paths`` more paths traced; ``error`` the direction's relative error (NaN without a target)."""

    def close(self) -> None:
        """The tracing ended (finished or interrupted)."""


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def prepare(plan: RunPlan, say: Callable[[str], None]):
    """The simulation of ``plan``, ready to trace: its walk and its estimator's models
    compiled (a notice while that takes a while, each one's time said apart) and the
    models computed.

    Returns
    -------
    vcavity.simulate.pipeline.Simulation

    Raises
    ------
    PlanError
        The estimator's model cannot reach the accuracy the run needs (one line).
    """
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.simulate.interrupts import pending, raise_if_pending
    from vcavity.simulate.pipeline import Simulation
    from vcavity.simulate.warmup import CompileNotice, Variant

    cfg = plan.config
    simulation = Simulation(cfg, threads=plan.threads, chunk_blocks=plan.request.chunk_blocks)
    if simulation.walk is not None and cfg.device == "cuda" and plan.request.dask is not None:
        say("the CUDA kernel is compiled (or loaded from their cache) on the Dask workers")  # not here: no GPU needed
    else:
        with CompileNotice(Variant.of_material(cfg.material).label):  # a line only when it takes a while
            compile_s = simulation.compile()
        raise_if_pending()  # a Ctrl-C that the compiler's callbacks swallowed
        if simulation.walk is not None:
            say(f"kernel ready in {compile_s:.2f} s (compile or cache load, not counted as run time)")
    if simulation.models is not None:
        code = simulation.models.CODE
        with CompileNotice(Variant.of_material(cfg.material).label, code=code):
            models_compile_s = simulation.compile_models()
        raise_if_pending()
        say(f"{code} code ready in {models_compile_s:.2f} s (compile or cache load, not counted as model time)")
    try:
        # a SIGTERM or Ctrl-C remembered but not raised stops the models between compiled calls
        model_s = simulation.prepare_models(should_stop=pending)
    except ModelNotApplicable as exc:
        raise PlanError(f"--estimator = {cfg.estimator}: {_first_line(exc)}") from None
    if simulation.models is not None:
        say(simulation.models.ready_line(model_s))
    return simulation


def execute(plan: RunPlan, simulation, say: Callable[[str], None], progress: Progress | None = None,
            executor=None) -> TableValue | None:
    """Trace ``plan``'s paths from its state and write its table; returns the table, or None
    when interrupted (what was kept is said).

    Ctrl-C is deferred (:class:`vcavity.simulate.interrupts.DeferredInterrupt`): between
    chunks it stops the run with a checkpoint; during the table write it cancels the rename
    (the old table stays) and the checkpoint, saved with the finished state just before,
    keeps the run: ``--resume`` then only writes the table.

    Parameters
    ----------
    executor : callable, optional
        Runs the work units elsewhere (:class:`vcavity.simulate.dask.DaskExecutor`); the
        caller closes it.

    Raises
    ------
    PlanError
        A checkpoint or the table could not be written (disk full, ...): one line saying
        what was kept.
    """
    from vcavity.io.writer import write_table
    from vcavity.simulate.interrupts import DeferredInterrupt
    from vcavity.simulate.pipeline import RunInterrupted

    out = plan.output
    path = checkpoint.checkpoint_path(out.path)
    planned = simulation.total_paths

    def save(current):
        # a failed save must not pass for a failed table write: the run would claim a
        # checkpoint that does not exist (the error says which file failed)
        previous = path.is_file()
        try:
            run_state.save(path, current, plan.config, planned)
        except OSError as exc:
            kept = "the previous checkpoint is unchanged" if previous else "no checkpoint was kept"
            message = f"writing the checkpoint {str(path)!r} failed ({exc.strerror or exc})"
            raise PlanError(f"{out.field} = {out.shown!r}: {message}; no table written, an existing file is "
                            f"unchanged; {kept}") from None

    with DeferredInterrupt() as interrupt:
        try:
            table = simulation.run(on_progress=None if progress is None else progress.advance, state=plan.state,
                                   on_checkpoint=save, checkpoint_every_s=plan.request.checkpoint_every_s,
                                   should_stop=interrupt.cancelled, executor=executor)
        except RunInterrupted as interrupted:
            if progress is not None:
                progress.close()
            save(interrupted.state)
            done = int(simulation.paths_done(interrupted.state).sum())
            say(f"interrupted; checkpoint {path} saved ({done:,} of {planned:,} paths): continue with --resume")
            return None
        if progress is not None:
            progress.close()
        save(simulation.last_state)  # a write cut short (Ctrl-C, kill, full disk) then loses no path
        try:
            write_table(out.path, table, cancelled=interrupt.cancelled)
        except KeyboardInterrupt:
            say(f"interrupted while writing {out.path}: nothing written, an existing table untouched; "
                f"checkpoint {path} holds the finished run: --resume writes the table")
            return None
        except OSError as exc:
            reason = exc.strerror or _first_line(exc)
            raise PlanError(f"{out.field} = {out.shown!r}: writing the table failed ({reason}); nothing was written "
                            "and an existing file is unchanged; the checkpoint keeps the run") from None
    path.unlink(missing_ok=True)  # the table holds everything now
    return table


def connect(address: str, config=None):
    """The Dask executor of ``--dask ADDRESS`` (:class:`vcavity.simulate.dask.DaskExecutor`),
    its workers checked for ``config``'s device (:func:`check_workers`).

    Raises
    ------
    PlanError
        No ``dask.distributed``, no scheduler answers, or the workers cannot run the
        walk on the config's device (one line).
    """
    from vcavity.simulate.dask import DaskExecutor, parse_address

    device = "cpu" if config is None else config.device
    try:
        parse_address(address)
        executor = DaskExecutor(address, device=device)
    except (ValueError, ImportError, OSError) as exc:
        raise PlanError(f"--dask = {address!r}: {_first_line(exc)}") from None
    try:
        if config is not None:
            check_workers(executor, config, address)
    except BaseException:
        executor.close()
        raise
    return executor


def check_workers(executor, config, address: str) -> None:
    """On ``config.device = "cuda"``: whether every Dask worker can run the CUDA walk
    (numba-cuda, a GPU, room for a launch's tally), before anything is traced; the tables
    then record the workers' GPUs (:meth:`vcavity.simulate.dask.DaskExecutor.check_cuda`).

    Raises
    ------
    PlanError
        ``simulation.device = 'cuda': the Dask workers (--dask = '...') cannot run it: worker ...: why``.
    """
    if config.device != "cuda":
        return
    n_cells = config.sensor_resolution ** 2
    try:
        executor.check_cuda(8 * (config.max_order + 1) * n_cells)
    except (ValueError, OSError) as exc:
        raise PlanError(f"simulation.device = {config.device!r}: the Dask workers (--dask = {address!r}) cannot run "
                        f"it: {_first_line(exc)}") from None


__all__ = ["Progress", "check_workers", "connect", "execute", "prepare"]
