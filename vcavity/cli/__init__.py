"""Command-line interface: ``vcavity run``, ``info``, ``compare``, ``plot``, ``sweep`` and ``export``.

Exit status: 0 success (compare: the test passed); 1 compare: the test failed; 2 bad input
(config, arguments, output path, unreadable table, model not applicable, not enough memory
or disk, a write that failed) with a one-line message and no output file; 130 interrupted
(Ctrl-C: one line, no output file written or changed).
"""

from __future__ import annotations

import argparse
import signal
import sys

from vcavity.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_TEST_FAILED,
    PATHS_MAX,
    Parser,
    count_arg,
    error,
    first_line,
    fraction_arg,
    open_table_or_error,
    run_epilog,
    seconds_arg,
    seed_arg,
)


def build_parser() -> argparse.ArgumentParser:
    """The ``vcavity`` argument parser (exposed for documentation and tests)."""
    parser = Parser(
        prog="vcavity",
        description="Monte-Carlo simulation of light in microfacet V-cavities: "
        "BRDF tables per bounce order (f1, f2, ..., f_inf) with error bars.",
    )
    from vcavity._version import __version__

    parser.add_argument("--version", action="version", version=f"vcavity {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    run = sub.add_parser(
        "run",
        help="simulate a run config and write an HDF5 table",
        description="Simulate light paths in V-cavities for each incident direction of a run "
        "config and write the BRDF table per bounce order to HDF5.",
        epilog_factory=run_epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
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

    info = sub.add_parser("info", help="print a human summary of a table",
                          description="Print the material, budget, albedo per order, absorbed and truncated energy of a table.")
    info.add_argument("table", metavar="OUT.h5")

    compare = sub.add_parser(
        "compare", help="compare a table with an analytic model (exit 0 pass, 1 fail)",
        description="Compare a table with an analytic model: albedos, relative L1 over the "
        "hemisphere (with the value noise alone gives), and a Pearson chi-square test of the f1 "
        "counts against the V-cavity single-bounce model, its exact expectation. Exit status 0 "
        "when that test passes for every incident direction (Sidak-corrected), 1 when it fails, "
        "2 for bad input (not a table, missing dataset or order, model not applicable).")
    compare.add_argument("table", metavar="OUT.h5")
    compare.add_argument("--model", default="vcavity", choices=("vcavity", "smith", "smith-hc", "oren-nayar"),
                         help="model for albedo and L1: single-bounce with V-cavity, Smith separable or "
                         "height-correlated G2 (vs f1), or Oren-Nayar (vs f1 + f2; gaussian, eta = 1)")
    compare.add_argument("--plots", metavar="DIR", help="write one comparison PNG per incident direction to DIR")
    compare.add_argument("--significance", type=fraction_arg, default=0.01, metavar="A",
                         help="family-wise false-alarm rate of the chi-square tests (default 0.01)")
    compare.add_argument("--nodes", type=count_arg(1, 1024), default=64, metavar="N",
                         help="body-integral nodes per axis of the model (accuracy control, default 64, "
                         "at most 1024: the cost grows as N^2 per cell)")
    compare.add_argument("--lambda-fit", action="store_true",
                         help="Smith models on beckmann: Walter's rational Lambda instead of the exact erf form")
    from vcavity.cli.plot import add_plot_parser  # `vcavity plot` lives in cli_plot.py

    add_plot_parser(sub)
    from vcavity.cli.sweep import add_sweep_parser  # `vcavity sweep` lives in cli_sweep.py

    add_sweep_parser(sub)
    from vcavity.cli.export import add_export_parser  # `vcavity export` lives in cli_export.py

    add_export_parser(sub)
    return parser


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


def _cmd_run(args) -> int:
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


def _cmd_info(args) -> int:
    from pathlib import Path

    from vcavity.io.sweep_table import is_sweep_file

    # a sweep file (vcavity sweep): its own summary; only regular files (h5py blocks on a FIFO)
    if Path(args.table).is_file() and is_sweep_file(args.table):
        from vcavity.cli.sweep import cmd_sweep_info

        return cmd_sweep_info(args)
    from vcavity.io import checkpoint

    if Path(args.table).is_file() and checkpoint.is_checkpoint(args.table):  # a partial run
        from vcavity.simulate.driver import describe_checkpoint

        try:
            print(describe_checkpoint(args.table))
        except (OSError, KeyError, ValueError) as exc:
            return error(f"checkpoint {args.table!r}: cannot read it ({first_line(exc, '')})")
        return EXIT_OK
    from vcavity.io.summary import format_summary

    table = open_table_or_error(args.table)
    if table is None:
        return EXIT_BAD_INPUT
    print(format_summary(table, verbose=True))
    return EXIT_OK


def _cmd_compare(args) -> int:
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.compare import compare_table, format_report
    from vcavity.io.preflight import PreflightError, check_plots_folder

    if not 0.0 < args.significance < 1.0:
        return error(f"--significance = {args.significance}: must be in (0, 1)")
    if args.plots is not None:
        try:
            check_plots_folder(args.plots)
        except PreflightError as exc:
            return error(str(exc))
    table = open_table_or_error(args.table)
    if table is None:
        return EXIT_BAD_INPUT
    if 1 in table.order and table.is_analytic(1):
        return error(f"table {args.table!r}: f1 is analytic in this table (estimator {table.estimator}), "
                      "there is no simulated f1 to test; run with --estimator analog to validate the walk")
    try:
        report = compare_table(table, model=args.model, significance=args.significance, n_nodes=args.nodes,
                               lambda_fit=args.lambda_fit, plots_dir=args.plots)
    except ModelNotApplicable as exc:
        return error(first_line(exc))
    print(format_report(report))
    if args.plots:
        print(f"plots written to {args.plots}")
    return EXIT_OK if report.passed else EXIT_TEST_FAILED


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``vcavity`` console script.

    Ctrl-C anywhere (compiling, tracing, writing, comparing) ends with one line on stderr
    and exit status 130, never a traceback; ``run`` leaves no table and an old one untouched.
    """
    from vcavity.simulate import interrupts
    from vcavity.simulate.interrupts import is_interrupt

    args = argparse.Namespace()
    interrupts.reset()
    interrupts.install_main_handler()
    previous_hook = sys.unraisablehook
    try:
        status = _dispatch(args, argv)
        if status != EXIT_INTERRUPTED:
            interrupts.raise_if_pending()
        return status
    except BaseException as exc:
        # after a SIGINT that compiled code swallowed, what fails next (e.g. Numba's
        # "no compiled object yet") is a consequence of the interrupt, not a bug to show
        if not (is_interrupt(exc) or interrupts.pending()):
            raise
        # An interrupt inside Numba's compiler leaves half-built llvmlite objects whose
        # destructors complain at exit ("Exception ignored in ... ObjectRef.__del__"):
        # the process is ending on purpose, so such shutdown noise is not reported.
        sys.unraisablehook = lambda unraisable: None
        previous_hook = sys.unraisablehook
        if getattr(args, "table_written", None) is not None:
            print(f"vcavity: interrupted; the table was written: {args.table_written}", file=sys.stderr)
        elif getattr(args, "command", None) == "run":
            print("vcavity: interrupted; no table written", file=sys.stderr)
        else:
            print("vcavity: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        sys.unraisablehook = previous_hook
        if signal.getsignal(signal.SIGINT) is interrupts._main_handler:
            signal.signal(signal.SIGINT, signal.default_int_handler)


def _dispatch(args: argparse.Namespace, argv: list[str] | None) -> int:
    parser = build_parser()
    parser.parse_args(argv, namespace=args)
    if args.command == "run":
        return _cmd_run(args)
    if args.command == "info":
        return _cmd_info(args)
    if args.command == "compare":
        return _cmd_compare(args)
    if args.command == "plot":
        from vcavity.cli.plot import cmd_plot

        return cmd_plot(args)
    if args.command == "sweep":
        from vcavity.cli.sweep import cmd_sweep

        return cmd_sweep(args)
    if args.command == "export":
        from vcavity.cli.export import cmd_export

        return cmd_export(args)
    parser.error(f"unknown command {args.command!r}")
    return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
