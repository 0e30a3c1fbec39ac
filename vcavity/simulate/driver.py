"""A run as the command line drives it: checkpoints, resume, Ctrl-C, progress, the table.

``vcavity run`` calls :func:`run_to_table` once every input check has passed. It never
loses finished work: the run state is saved atomically to ``<OUT>.checkpoint`` every
``checkpoint_every_s`` seconds (``vcavity.io.checkpoint``), Ctrl-C (SIGINT) is turned into a
request to stop at the next chunk boundary, which saves a checkpoint, prints one line and
returns no result (the command exits with status 130), and the checkpoint is removed only once the table is written.
``--resume`` continues from the checkpoint; the final table is bitwise identical to an
uninterrupted run because the state is an integer tally of a prefix of each direction's
blocks and later blocks do not depend on earlier ones.
"""

from __future__ import annotations

import sys
from pathlib import Path

from vcavity.io import checkpoint

def _say(message: str) -> None:
    print(f"vcavity: {message}", file=sys.stderr)


def load_state(simulation, output: Path, resume: bool):
    """The state to start from: the checkpoint's with ``resume``, else None.

    Raises
    ------
    vcavity.io.checkpoint.CheckpointError
        Unusable checkpoint with ``resume`` (one line), or an existing checkpoint of an
        unfinished run without ``resume``.
    """
    path = checkpoint.checkpoint_path(output)
    checkpoint.refuse_non_file(path)  # a folder there is neither resumed nor replaced
    if not resume:
        if path.exists():
            raise checkpoint.CheckpointError(
                f"checkpoint {str(path)!r} of an unfinished run exists: --resume to continue it, or "
                "--overwrite to start afresh (it is then replaced)")
        return None
    if not path.exists():
        _say(f"--resume: no checkpoint {str(path)!r}; starting from the first path")
        return None
    state = checkpoint.load(path, simulation.config.to_dict())
    done = int(simulation.paths_done(state).sum())
    _say(f"resuming from {path} ({done:,} of {simulation.total_paths:,} paths done)")
    return state


def run_to_table(simulation, output: Path, write, state=None, checkpoint_every_s: float = 60.0,
                 quiet: bool = False, executor=None):
    """Run ``simulation`` (from ``state``) and write its table with ``write(result, cancelled)``.

    Returns the run's result once its table is written, or None when interrupted (what was
    kept is said on stderr). Ctrl-C is
    deferred (:class:`vcavity.simulate.interrupts.DeferredInterrupt`): between chunks it stops the
    run with a checkpoint; during the table write it cancels the rename (the old table
    stays) and the checkpoint, saved with the finished state just before, keeps the run:
    ``--resume`` then only writes the table.

    Raises
    ------
    vcavity.io.checkpoint.CheckpointWriteError
        A checkpoint could not be saved (disk full, ...); an earlier one is unchanged.
    OSError
        The table could not be written; the checkpoint, saved just before, keeps the run.
    """
    from vcavity.simulate.interrupts import DeferredInterrupt
    from vcavity.simulate.pipeline import RunInterrupted

    path = checkpoint.checkpoint_path(output)
    config_dict = simulation.config.to_dict()

    def save(current):
        # a failed save must not pass for a failed table write: the run would claim a
        # checkpoint that does not exist (CheckpointWriteError says which file failed)
        previous = path.is_file()
        try:
            checkpoint.save(path, current, config_dict, int(simulation.paths_done(current).sum()),
                            simulation.total_paths)
        except OSError as exc:
            raise checkpoint.CheckpointWriteError(path, previous, exc.strerror or str(exc)) from None

    bar = None
    with DeferredInterrupt() as interrupt:
        on_progress = None
        if not quiet and simulation.total_paths > 0:  # the exact estimator traces nothing
            from tqdm import tqdm

            done = int(simulation.paths_done(state).sum()) if state is not None else 0
            bar = tqdm(total=simulation.total_paths, initial=done, unit="path", unit_scale=True,
                       dynamic_ncols=True, desc="tracing", file=sys.stderr)

            def show(paths_now, error):
                if error == error:  # not NaN: a target-error run reports its error
                    bar.set_postfix_str(f"error {error:.2e}", refresh=False)
                bar.update(paths_now)

            on_progress = show

        try:
            result = simulation.run(on_progress=on_progress, state=state, on_checkpoint=save,
                                    checkpoint_every_s=checkpoint_every_s, should_stop=interrupt.cancelled,
                                    executor=executor)
            final = simulation.last_state
        except RunInterrupted as interrupted:
            if bar is not None:
                bar.close()
            save(interrupted.state)
            done = int(simulation.paths_done(interrupted.state).sum())
            _say(f"interrupted; checkpoint {path} saved ({done:,} of {simulation.total_paths:,} paths): "
                 "continue with --resume")
            return None
        if bar is not None:
            bar.close()
        save(final)  # a write cut short (Ctrl-C, kill, full disk) then loses no path
        try:
            write(result, interrupt.cancelled)
        except KeyboardInterrupt:
            _say(f"interrupted while writing {output}: nothing written, an existing table untouched; "
                 f"checkpoint {path} holds the finished run: --resume writes the table")
            return None
    path.unlink(missing_ok=True)  # the table holds everything now
    return result


def describe_checkpoint(path) -> str:
    """What ``vcavity info`` prints for a checkpoint file."""
    summary = checkpoint.describe(path)
    done, planned = summary["paths_done"], summary["paths_planned"]
    source = summary["config"].get("source", "?")
    share = 100.0 * done / planned if planned else 0.0
    return (f"checkpoint: {path} (partial run of {source}): {done:,} of {planned:,} paths done ({share:.1f} %), "
            f"{summary['compute_time_s']:.1f} s traced; continue with: vcavity run ... --resume")
