"""Running a sweep point by point, writing the sweep file after each, and resuming it.

Each point is one run (:class:`vcavity.simulate.pipeline.Simulation`, the same pipeline as
``vcavity run``: plan, execute work units locally or on Dask, merge in block order). The
first point to finish writes the whole sweep file atomically
(:func:`vcavity.io.sweep_table.write_sweep`: every dataset allocated, contiguous); each
later point is committed in place into its own bytes, checksummed, its ``done`` flag last
(:class:`vcavity.io.sweep_points.PointWriter`), so the I/O of a point does not grow with
the number of points and a kill at any moment loses at most the running point.
``--resume`` reads the file back (a point whose checksum fails is read as not done),
checks that it holds the same sweep (``spec_digest``) and runs the points not done.
Stored values of finished points are read back exactly, so a resumed sweep writes the
same file as an uninterrupted one (apart from timings and the creation date).
"""

from __future__ import annotations

import json
import os
from typing import Callable

from vcavity.estimators import registry as estimators
from vcavity.io import preflight
from vcavity.io.sweep_points import NotInPlace, PointWriter
from vcavity.io.sweep_table import SweepData, SweepFormatError, open_sweep, write_sweep
from vcavity.simulate.plan import check_threads
from vcavity.sweep.spec import Point, Sweep, SweepError, overrides_text


#: What a sweep stores of each direction of a point's table, under the table's names.
PER_DIRECTION = ("brdf", "brdf_stderr", "counts", "albedo", "paths", "max_bounces_seen", "unbinned_paths", "folded",
                 "relative_error", "absorbed", "truncated", "degenerate", "target_reached")


def record(sweep: Sweep, data: SweepData, point: Point, value) -> None:
    """Store a finished point's table (:class:`~vcavity.io.schema.TableValue`) in ``data``:
    each direction's values as the table holds them, at the point's place in the grid."""
    for j in range(len(point.config.incidence)):
        where = sweep.grid_index(point, j)
        for name in PER_DIRECTION:
            data.data[name][where] = value[name][j]
    data.data["seed"][point.index] = point.config.seed
    data.data["compute_time_s"][point.index] = value.attrs["compute_time_s"]
    data.data["done"][point.index] = 1


def resume_data(sweep: Sweep, path, shown: str, field: str = "--output") -> SweepData:
    """The state of ``sweep`` stored at ``path`` (for ``--resume``); ``field = 'shown'``
    names the output in messages as the user gave it (``--output``, ``output.path``, or
    the default).

    Raises
    ------
    SweepError
        The file is not a sweep, was swept with other overrides (``--paths``, ``--seed``, ...),
        or holds another sweep (spec, base config or seed differ).
    """
    try:
        stored = open_sweep(path)
    except SweepFormatError as exc:
        raise SweepError(f"--resume: {field} = {shown!r} cannot be resumed: {exc}") from None
    stored_overrides = stored.attrs.get("overrides") or overrides_text({})  # files before overrides: none
    if stored_overrides != overrides_text(sweep.overrides):
        raise SweepError(f"--resume: {field} = {shown!r} was swept with the overrides "
                         f"{_overrides_shown(json.loads(stored_overrides))}, this command gives "
                         f"{_overrides_shown(sweep.overrides)}; give the same flags to continue it, another "
                         "--output, or --overwrite to start again")
    if stored.attrs.get("spec_digest") != sweep.digest:
        raise SweepError(f"--resume: {field} = {shown!r} holds another sweep (its axes, base config or seed "
                         "differ from this sweep file); give another --output, or --overwrite to start again")
    data = sweep.new_data()
    for name, array in data.data.items():
        array[...] = stored.data[name]
    data.path, data.rejected = stored.path, stored.rejected  # later points go into this file, in place
    return data


def _overrides_shown(overrides: dict) -> str:
    """``incidence.paths = 20000, simulation.seed = 3`` or ``none``."""
    return ", ".join(f"{field} = {value!r}" for field, value in sorted(overrides.items())) or "none"


def sweep_bytes(sweep: Sweep) -> int:
    """Size bound of the sweep file and of its arrays in memory: three 8-byte
    (grid, order, cell) arrays (``brdf``, ``brdf_stderr``, ``counts``) plus geometry."""
    first = sweep.points[0].config
    n_cells = first.sensor_resolution ** 2
    grid = len(sweep.points) * sweep.n_directions
    return 8 * (3 * grid * len(first.orders) * n_cells + 8 * n_cells) + (1 << 20)


def plan_output(sweep: Sweep, option: str | None, sweep_file: str | None, *, overwrite: bool = False,
                resume: bool = False, threads: int | None = None, locks=None):
    """Every check of a sweep that can fail, before anything is traced.

    Returns ``(output, data, note)``: the :class:`~vcavity.io.preflight.Output`, the sweep
    state to start from (a resumed file's, or empty) and a note for the user (or None).
    With ``locks`` (a :class:`contextlib.ExitStack`) the output's writer lock
    (:mod:`vcavity.io.lock`) is taken before the file is read and held until ``locks``
    closes: a second writer of the same file is refused here, naming the holder.

    Raises
    ------
    SweepError, vcavity.io.preflight.PreflightError, vcavity.simulate.plan.PlanError
        One line naming the flag or field.
    """
    if resume and overwrite:
        raise SweepError("--resume with --overwrite: give one (--resume continues the sweep in --output, "
                         "--overwrite starts it again)")
    out = preflight.resolve_output(option, sweep.output, sweep_file)
    preflight.check_output(out, sweep_file, True)  # links, folders, FIFOs, the sweep file itself
    # the lock first: another writer's file is neither judged nor read while it is written
    held = preflight.lock_output(out, locks) if locks is not None else None
    exists = out.path.exists()
    if exists and not (resume or overwrite):
        raise out.fail("exists; pass --resume to continue its sweep or --overwrite to start it again")
    threads = check_threads(threads)
    first = sweep.points[0].config
    n_cells = first.sensor_resolution ** 2
    tallies = len(estimators.get(first.estimator).TALLIES)
    needed = 2 * sweep_bytes(sweep) + preflight.run_memory_bytes(  # on CUDA one tally set, not one per thread
        sweep.n_directions, len(first.orders), first.max_order, n_cells, 1 if first.device == "cuda" else threads,
        tallies)
    available = preflight.available_memory()
    if available is not None and needed > available:
        raise preflight.PreflightError(
            f"simulation.sensor_resolution = {first.sensor_resolution} with max_order = {first.max_order}: "
            f"the sweep needs about {needed / 1024**3:,.2f} GB of memory ({len(sweep.points)} point(s) x "
            f"{sweep.n_directions} direction(s) x {len(first.orders)} orders x {n_cells:,} cells), "
            f"{available / 1024**3:,.2f} GB available; accepted: a sweep that fits (fewer points, lower "
            "sensor_resolution or max_order)")
    note = held.note() if held is not None else None
    data = resume_data(sweep, out.path, out.shown, out.field) if resume and exists else sweep.new_data()
    if resume and not exists:
        note = _join(note, f"{out.shown}: nothing to resume yet, starting the sweep")
    if data.rejected:
        note = _join(note, f"{out.shown}: {len(data.rejected)} point(s) marked done fail their checksum (a write "
                     "cut short or changed bytes); they are run again")
    removed = preflight.probe_output(out)
    preflight.check_disk_space(out, sweep_bytes(sweep))
    if removed:
        note = _join(note, f"removed {len(removed)} stale temporary file(s) of interrupted writes")
    return out, data, note


def _join(note: str | None, extra: str) -> str:
    """``note; extra``, or ``extra`` alone."""
    return extra if note is None else f"{note}; {extra}"


def run(sweep: Sweep, output, data: SweepData, *, threads: int | None = None, chunk_blocks: int | None = None,
        executor=None, on_progress: Callable[..., None] | None = None,
        on_point: Callable[[Point, SweepData], None] | None = None,
        should_stop: Callable[[], bool] | None = None) -> SweepData:
    """Run every point of ``sweep`` not yet done in ``data``, writing ``output`` after each.

    Parameters
    ----------
    sweep : Sweep
    output : path
        The sweep file, rewritten atomically after each finished point.
    data : SweepData
        The state to start from (:meth:`Sweep.new_data` or :func:`resume_data`); updated
        in place, so after an interruption it holds every finished point.
    threads, chunk_blocks : int, optional
        As for :class:`~vcavity.simulate.pipeline.Simulation`; neither changes the result.
    executor : callable, optional
        Executor of each point's work units (e.g. :class:`vcavity.simulate.dask.DaskExecutor`).
    on_progress : callable, optional
        ``on_progress(paths_now, relative_error)`` after each chunk, as in a run.
    on_point : callable, optional
        ``on_point(point, data)`` after each point is written (an exception raised there
        stops the sweep with that point stored).
    should_stop : callable, optional
        The stop request (Ctrl-C), polled between chunks and by a point's analytic models
        between their short compiled calls: when it returns True the running point is
        dropped and ``KeyboardInterrupt`` raised (the points before it are stored).

    Raises
    ------
    vcavity.analytic.single_bounce.ModelNotApplicable
        Estimator exact-f1 and a point's model cannot reach the accuracy (points before it
        are stored).
    KeyboardInterrupt
        ``should_stop`` returned True (points before the running one are stored).
    OSError
        Writing the file failed (the previous file is intact).
    """
    from vcavity.simulate.pipeline import RunInterrupted, Simulation

    writer = _attach(output, data)
    try:
        for point in sweep.points:
            if data.data["done"][point.index]:
                continue
            simulation = Simulation(point.config, threads=threads, chunk_blocks=chunk_blocks)
            try:
                result = simulation.run(on_progress=on_progress, executor=executor, should_stop=should_stop)
            except RunInterrupted:  # the running point is dropped, as on a Ctrl-C between chunks
                raise KeyboardInterrupt from None
            record(sweep, data, point, result)
            if writer is None:  # a new sweep, or a file from before in-place commits: written whole once
                write_sweep(output, data)
                writer = PointWriter(output, data)
            else:
                writer.commit(point.index)
            if on_point is not None:
                on_point(point, data)
    finally:
        if writer is not None:
            writer.close()
    return data


def _attach(output, data: SweepData) -> PointWriter | None:
    """The writer of the file ``data`` was resumed from, when points remain and it takes
    them in place; None when the first finished point writes the whole file."""
    resumed = data.path is not None and os.path.abspath(data.path) == os.path.abspath(output)
    if not resumed or data.n_done() == data.data["done"].size:
        return None
    try:
        return PointWriter(output, data)
    except NotInPlace as exc:
        if exc.convertible:
            return None
        raise OSError(f"{output} changed since it was read ({exc}); it was not replaced") from None


def traces(sweep: Sweep) -> bool:
    """Whether any point of ``sweep`` traces paths (not so with the exact estimator: its
    tables are the model's, and a sweep's progress is then counted in points)."""
    return any(estimators.get(p.config.estimator).walk(p.config.material) is not None for p in sweep.points)


def paths_done(sweep: Sweep, data: SweepData) -> int:
    """Paths of the points already done (where a progress bar starts)."""
    return sum(sweep.point_paths(p) for p in sweep.points if data.data["done"][p.index])


__all__ = ["paths_done", "plan_output", "record", "resume_data", "run", "sweep_bytes", "traces"]
