"""``vcavity sweep``: run a grid of configs into one HDF5 file.

Exit status as for ``run``: 0 done, 2 bad input (one line naming the field or flag, no
file written or changed), 130 interrupted (finished points stay in the file; ``--resume``
continues).
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from vcavity.cli.common import EXIT_INTERRUPTED, EXIT_OK, error, first_line, written
from vcavity.cli.tracing import ProgressBar, add_run_flags, budget_overrides, name_the_flag

NAME = "sweep"

_SWEEP_EPILOG = """\
sweep file (TOML): a run config ([material], [incidence], [simulation], [output]) as the
base, plus a [sweep] table of grid axes, each a list of values:
  [sweep]
  alpha = [0.1, 0.3, 0.6, 1.0]   # any parameter of the distribution or the facet model:
  eta = [1.0, 1.5, 2.0]          #   alpha (or alpha_x, alpha_y: separate axes), gamma,
  theta_i_deg = [0, 45, 70]      #   exponent, sigma, kd, eta; and distribution, phi_i_deg
The grid is the Cartesian product. A point (one material: every axis but theta_i_deg and
phi_i_deg) is one run over every incident direction; its seed is a hash of
simulation.seed and its material, so adding or reordering values of an axis does not
change the other points. incidence.paths (one value) is the paths of every direction.

paired axes: one axis whose points set several keys together (equal-length lists, one
label list naming the points, label or label_<units>), e.g. a metal per wavelength:
  [sweep.paired.wavelength]
  label_nm = [659.5, 548.6, 450.9]   # the axis values
  eta = [0.14, 0.43, 1.38]           # point j sets eta[j] and k[j] together
  k = [3.697, 2.455, 1.914]          # (gold, Johnson & Christy 1972)
The lists it sets are stored as coordinates along the axis (eta(wavelength), ...).

budget flags: --paths, --seed, --estimator, --target-error, --max-paths and --device mean
what they mean for vcavity run and override incidence.paths and the [simulation] keys at every
point (e.g. a quick trial: --paths 20000); the file records them (attribute overrides),
and --resume continues a sweep only with the same ones.

output: one HDF5 file, brdf(alpha, eta, theta_i_deg, order, cell), albedo, counts, ...
readable with xarray.open_dataset(OUT, engine="h5netcdf"); created when the first point
finishes, then each point written in place (its values, a checksum, its done flag last),
so an interrupted sweep keeps its finished points: continue it with --resume. While it
runs it holds OUT.h5.lock: a second sweep or run into OUT.h5 is refused (exit status 2).
docs/sweeps.md; examples: runs/sweep_roughness_eta.toml, runs/sweep_gold_rgb.toml
"""


def add_parser(subparsers) -> None:
    """Add the ``sweep`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    sweep = subparsers.add_parser(
        NAME, help="run a grid of configs (a sweep file) into one HDF5 file",
        description="Simulate every point of a parameter grid and write the tables into one HDF5 "
        "file with the grid axes as leading dimensions.",
        epilog=_SWEEP_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    sweep.set_defaults(handler=command)
    sweep.add_argument("sweep", metavar="SWEEP.toml", help="sweep file: a run config plus a [sweep] table")
    add_run_flags(sweep, NAME)


def command(args: argparse.Namespace) -> int:
    """``vcavity sweep SWEEP.toml -o OUT.h5 [--resume | --overwrite]``.

    Returns the exit status (:mod:`vcavity.cli.common`).
    """
    from vcavity.simulate.plan import (PlanError, check_dask_address, check_dask_work, check_device,
                                       check_device_memory)
    from vcavity.sweep import spec as sweep_mod
    from vcavity.sweep import run as sweep_run
    from vcavity.io.preflight import PreflightError

    try:
        check_dask_address(args.dask)
    except PlanError as exc:
        return error(str(exc))

    overrides = budget_overrides(args)
    try:
        spec = sweep_mod.load(args.sweep, overrides=overrides)
    except sweep_mod.SweepError as exc:
        return error(name_the_flag(str(exc), overrides))
    try:
        for point in spec.points:  # the device's and Dask's refusals, before the file is touched
            check_device(point.config, args.dask)
            check_dask_work(point.config, args.dask)
            check_device_memory(point.config, point.config.sensor_resolution ** 2, args.dask)
    except PlanError as exc:
        return error(name_the_flag(str(exc), overrides))
    # the output's writer lock, held to the end of the command (io/lock.py): a second
    # sweep or run into the same file is refused in plan_output, before it reads or writes
    with contextlib.ExitStack() as locks:
        try:
            output, data, note = sweep_run.plan_output(spec, args.output, args.sweep, overwrite=args.overwrite,
                                                       resume=args.resume, threads=args.threads, locks=locks)
        except (sweep_mod.SweepError, PreflightError, PlanError) as exc:
            return error(str(exc))
        return _locked(args, spec, output, data, note, overrides)


def _locked(args, spec, output, data, note, overrides) -> int:
    """The sweep once its output is locked: connect, trace, write, report."""
    if note:
        print(f"vcavity: {note}", file=sys.stderr)
    executor = None
    if args.dask is not None:
        from vcavity.simulate.dask import DaskExecutor
        from vcavity.simulate.plan import PlanError
        from vcavity.simulate.service import check_workers

        first = spec.points[0].config  # (the device is every point's: part of the digest)
        try:
            executor = DaskExecutor(args.dask, threads_per_task=args.threads or 1, device=first.device)
        except (ImportError, ValueError, OSError) as exc:  # OSError: no scheduler answers (a timeout)
            return error(f"--dask = {args.dask!r}: cannot use it ({first_line(exc)})")
        try:
            check_workers(executor, first, args.dask)  # CUDA: each worker has numba-cuda and a GPU
        except PlanError as exc:
            executor.close()
            return error(name_the_flag(str(exc), overrides))
    from vcavity.sweep import run as sweep_run

    n_points = len(spec.points)
    total = sum(spec.point_paths(p) for p in spec.points) if sweep_run.traces(spec) else 0
    work = f"{total:,} paths in all" if total else f"no path ({spec.points[0].config.estimator} estimator)"
    print(f"vcavity: {spec.source}: {n_points} point(s) x {spec.n_directions} direction(s), "
          f"{data.n_done()} done, {work}"
          + "".join(f"; {field} = {value!r} (override)" for field, value in overrides.items()), file=sys.stderr)
    try:
        return _trace(args, spec, output, data, executor, total)
    except KeyboardInterrupt:
        if args.overwrite and data.n_done() == 0 and output.path.exists():
            # --overwrite replaces the old file with the first finished point: none finished
            print(f"vcavity: interrupted; no point finished, {output.path} is unchanged (start again with: "
                  f"vcavity sweep {args.sweep} -o {output.path} --overwrite)", file=sys.stderr)
            return EXIT_INTERRUPTED
        kept = (f"{data.n_done()} of {n_points} point(s) are in {output.path}" if output.path.exists()
                else f"no point finished, nothing written to {output.path}")
        print(f"vcavity: interrupted; {kept} (continue with: vcavity sweep {args.sweep} -o {output.path} --resume)",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if executor is not None:
            executor.close()


def _trace(args, spec, output, data, executor, total) -> int:
    """Run the points not done yet, Ctrl-C deferred to between kernel calls and writes."""
    from vcavity.sweep import run as sweep_run
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.simulate.interrupts import DeferredInterrupt
    from vcavity.io.sweep_table import open_sweep
    from vcavity.io.sweep_summary import format_sweep_summary

    # Ctrl-C only sets a flag, checked between kernel calls and after each point's write:
    # a point being written is completed, the running one is dropped.
    with DeferredInterrupt() as interrupt:
        bar = None
        if not args.quiet:  # paths; points where no point traces any (the exact estimator)
            bar = (ProgressBar(total, sweep_run.paths_done(spec, data), "sweeping") if total else
                   ProgressBar(len(spec.points), data.n_done(), "sweeping", unit="point"))

        def progress(paths_now, error):
            interrupt.check()
            if bar is not None:
                bar.advance(paths_now, float("nan"))  # a point's own error: no target across points

        def point_done(point, data):
            if bar is not None and not total:
                bar.advance(1, float("nan"))
            interrupt.check()

        failure = None
        try:
            sweep_run.run(spec, output.path, data, threads=args.threads, chunk_blocks=args.chunk_blocks,
                          executor=executor, on_progress=progress, on_point=point_done,
                          should_stop=interrupt.cancelled)  # polled by an exact point's models too
        except ModelNotApplicable as exc:
            failure = (f"simulation.estimator = {spec.points[0].config.estimator!r}: {first_line(exc)} "
                       f"({data.n_done()} point(s) done are in {output.path})")
        except OSError as exc:
            reason = exc.strerror or first_line(exc)
            kept = "the file holds the points finished before" if output.path.exists() else "nothing was written"
            failure = f"{output.field} = {output.shown!r}: writing the sweep failed ({reason}); {kept}"
        finally:
            if bar is not None:
                bar.close()  # before any line: no bar fragment on the error's line
        if failure is not None:
            return error(failure)
    written(output.path)  # a Ctrl-C from here on (the summary, Dask's shutdown) says the file is complete
    print(f"wrote {output.path}")
    print(format_sweep_summary(open_sweep(output.path)))
    return EXIT_OK
