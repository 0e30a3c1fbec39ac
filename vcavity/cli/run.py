"""``vcavity run``: simulate a run config and write its BRDF table to HDF5.

Exit status: 0 written; 2 bad input (config, flags, output path, not enough memory or
disk, model not applicable, a write that failed), one line and no output file; 130
interrupted (the checkpoint keeps the run; ``--resume`` continues it).
"""

from __future__ import annotations

import argparse
import sys

from vcavity.cli.common import (
    EXIT_OK,
    PATHS_MAX,
    count_arg,
    error,
    first_line,
    fraction_arg,
    run_epilog,
    seconds_arg,
    seed_arg,
)

NAME = "run"


def add_parser(subparsers) -> None:
    """Add the ``run`` sub-parser, whose handler is :func:`command`.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``vcavity`` parser's subcommands.
    """
    run = subparsers.add_parser(
        NAME,
        help="simulate a run config and write an HDF5 table",
        description="Simulate light paths in V-cavities for each incident direction of a run "
        "config and write the BRDF table per bounce order to HDF5.",
        epilog_factory=run_epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.set_defaults(handler=command)
    run.add_argument("config", nargs="?", metavar="CONFIG.toml", help="run config (default: built-in figure 7 run)")
    run.add_argument("-o", "--output", metavar="OUT.h5",
                     help="output table (default: [output].path, else CONFIG with .h5, else ./vcavity-default.h5)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace an existing table (atomically, only when the run completes); without it an "
                     "existing output is refused before anything runs")
    run.add_argument("--paths", type=count_arg(1, PATHS_MAX), metavar="N",
                     help="paths per incident direction, e.g. 1e6 (overrides the config)")
    run.add_argument("--threads", type=count_arg(1, 4096), metavar="T", help="worker threads (default: all cores)")
    run.add_argument("--seed", type=seed_arg, metavar="S", help="random seed, 0 .. 2**64-1 (overrides the config)")
    run.add_argument("--chunk-blocks", type=count_arg(1, 2**40), metavar="B",
                     help="RNG blocks of 4096 paths per kernel call (default 512; does not change results)")
    run.add_argument("--estimator", choices=("analog", "exact-f1", "paper"),
                     help="analog: every order simulated (default); exact-f1: f1 from the exact V-cavity "
                     "single-bounce model, orders >= 2 simulated; paper: the IL paper's eq. 23 (paths start "
                     "on a facet, weighted by its lit projected area) (overrides [simulation] estimator)")
    run.add_argument("--target-error", type=fraction_arg, metavar="E",
                     help="run each direction until the energy-weighted mean relative standard error of "
                     "f_inf is at most E (e.g. 0.002), checked every 64 blocks of 4096 paths")
    run.add_argument("--max-paths", type=count_arg(1, PATHS_MAX), metavar="N",
                     help="with --target-error: the most paths per direction (default: the config's paths)")
    run.add_argument("--resume", action="store_true",
                     help="continue the interrupted run of OUT.h5 from its checkpoint OUT.h5.checkpoint (same "
                     "config and seed; the table equals an uninterrupted run's, bit for bit)")
    run.add_argument("--checkpoint-every", type=seconds_arg, default=60.0, metavar="S",
                     help="save the run's progress to OUT.h5.checkpoint every S seconds (default 60); Ctrl-C "
                     "saves it too and exits 130; removed once the table is written")
    run.add_argument("--dask", metavar="ADDRESS",
                     help="run the work units on a Dask cluster: a scheduler address (tcp://host:8786) or "
                     "local:N for N local worker processes (needs vcavity[distributed]; docs/distributed.md); "
                     "the table is the local run's, bit for bit")
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _preflight(args, cfg):
    """Every check of a run that can fail, before compiling or tracing (vcavity/io/preflight.py).

    Returns the :class:`~vcavity.io.preflight.Output`; raises ``PreflightError`` (one line).
    """
    import numba

    from vcavity.io import preflight
    from vcavity.sensor.grid import EqualAreaSensor

    out = preflight.resolve_output(args.output, cfg.output, args.config)
    from vcavity.io.checkpoint import checkpoint_path

    resuming = bool(getattr(args, "resume", False)) and checkpoint_path(out.path).exists()
    preflight.check_output(out, args.config, args.overwrite or resuming)
    if args.threads is not None and args.threads > numba.config.NUMBA_NUM_THREADS:
        raise preflight.PreflightError(f"--threads = {args.threads}: must be between 1 and "
                                       f"{numba.config.NUMBA_NUM_THREADS} (cores here)")
    n_cells = EqualAreaSensor(cfg.sensor_resolution).n_cells
    preflight.check_memory(cfg, args.threads or numba.config.NUMBA_NUM_THREADS, n_cells)
    removed = preflight.probe_output(out)  # creates and removes a file: /proc, /sys, read-only
    preflight.check_disk_space(out, preflight.table_bytes(len(cfg.incidence), len(cfg.orders), n_cells))
    if removed:
        print(f"vcavity: removed {len(removed)} stale temporary file(s) of interrupted writes: "
              f"{', '.join(p.name for p in removed)}", file=sys.stderr)
    return out


_FLAG_OF = {"simulation.estimator": "--estimator", "simulation.target_error": "--target-error",
            "simulation.max_paths": "--max-paths"}


def command(args) -> int:
    """``vcavity run [CONFIG.toml] [-o OUT.h5] ...``: simulate, write the table, summarise it."""
    import dataclasses

    from vcavity import config as config_mod

    try:
        cfg = config_mod.load(args.config) if args.config else config_mod.default_config()
        if args.paths is not None:
            cfg = dataclasses.replace(
                cfg, incidence=tuple(dataclasses.replace(d, paths=args.paths) for d in cfg.incidence)
            )
        if args.seed is not None:
            cfg = dataclasses.replace(cfg, seed=args.seed)
        overrides = {name: value for name, value in (("estimator", args.estimator),
                     ("target_error", args.target_error), ("max_paths", args.max_paths)) if value is not None}
        if args.max_paths is not None and args.target_error is None and cfg.target_error is None:
            return error(f"--max-paths = {args.max_paths}: applies only with --target-error "
                          "(otherwise --paths is the number of paths)")
        if overrides:
            try:
                cfg = cfg.replace(**overrides)
            except config_mod.ConfigError as exc:  # name the flag the value came from
                field = str(exc).split(" ", 1)[0]
                if field not in _FLAG_OF or field.split(".")[1] not in overrides:
                    raise
                raise config_mod.ConfigError(_FLAG_OF[field] + str(exc)[len(field):]) from None
    except config_mod.ConfigError as exc:
        return error(str(exc))
    from vcavity.io.preflight import PreflightError

    try:
        output = _preflight(args, cfg)
    except PreflightError as exc:
        return error(str(exc))
    out = output.path

    from vcavity.io.writer import write_result
    from vcavity.io.summary import format_summary
    from vcavity.simulate.pipeline import Simulation

    sim = Simulation(cfg, threads=args.threads, chunk_blocks=args.chunk_blocks)
    print(f"vcavity: {cfg.source}: {len(cfg.incidence)} incident direction(s), "
          f"{sim.total_paths:,} paths, {sim.threads} thread(s)", file=sys.stderr)
    from vcavity.io import checkpoint
    from vcavity.simulate import driver as runner

    try:
        state = runner.load_state(sim, out, args.resume or False)
    except checkpoint.CheckpointError as exc:
        if not (args.overwrite and not args.resume and "unfinished run exists" in str(exc)):
            return error(str(exc))
        state = None  # --overwrite: start afresh; the old checkpoint is replaced by the first save
    compile_s = sim.compile()
    from vcavity.simulate.interrupts import raise_if_pending

    raise_if_pending()  # a Ctrl-C that the compiler's callbacks swallowed
    print(f"vcavity: kernel ready in {compile_s:.2f} s (compile or cache load, not counted as run time)",
          file=sys.stderr)
    from vcavity.analytic.single_bounce import ModelNotApplicable

    try:
        model_s = sim.prepare_models()
    except ModelNotApplicable as exc:
        return error(f"--estimator = exact-f1: {first_line(exc)}")
    if cfg.estimator == "exact-f1":
        print(f"vcavity: exact f1 model ready in {model_s:.2f} s", file=sys.stderr)
    executor = None
    if args.dask:
        from vcavity.simulate.dask import DaskExecutor, parse_address

        try:
            parse_address(args.dask)
            executor = DaskExecutor(args.dask)
        except (ValueError, ImportError, OSError) as exc:
            return error(f"--dask = {args.dask!r}: {first_line(exc)}")
    cfg = dataclasses.replace(cfg, output=out.resolve())  # the table records where it was written

    def write(result, cancelled):
        write_result(out, result, cfg, cancelled=cancelled)

    try:
        status, result = runner.run_to_table(sim, out, write, state=state, checkpoint_every_s=args.checkpoint_every,
                                             quiet=args.quiet, executor=executor)
    except OSError as exc:
        reason = exc.strerror or first_line(exc)
        return error(f"{output.field} = {output.shown!r}: writing the table failed ({reason}); "
                      "nothing was written and an existing file is unchanged; the checkpoint keeps the run")
    finally:
        if executor is not None:
            executor.close()
    if status != EXIT_OK:
        return status
    args.table_written = out
    traced = int(result.paths.sum())
    rate = traced / result.compute_time_s if result.compute_time_s > 0 else float("inf")
    if cfg.target_error is not None:
        for d, paths, rel_error, reached in zip(cfg.incidence, result.paths, result.relative_error,
                                            result.target_reached):
            state = "reached" if reached else "NOT reached: path cap hit"
            print(f"theta_i = {d.theta_i_deg:g} deg: target error {cfg.target_error:g} {state} "
                  f"(error {rel_error:.3g} after {int(paths):,} paths)")
    print(f"wrote {out}")
    print(f"run time {result.compute_time_s:.2f} s ({rate / 1e6:.2f} M paths/s), "
          f"kernel compile/load {result.compile_time_s:.2f} s")
    from vcavity.io.table import open_table

    print(format_summary(open_table(out)))
    return EXIT_OK
