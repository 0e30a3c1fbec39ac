"""Command-line interface: ``vcavity run``, ``vcavity info`` and ``vcavity compare``.

Exit status: 0 success (compare: the test passed); 1 compare: the test failed; 2 bad input
(config, arguments, unreadable table, model not applicable) with a one-line message and
no output file; 130 interrupted (no output file written or changed).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

_RUN_EPILOG_TAIL = """\
  [incidence]  theta_i_deg = [0, 30, 60, 80]   phi_i_deg = 0   paths = 10000000
               (phi_i_deg and paths: one value, or one per theta_i_deg)
  [simulation] seed = 1   max_order = 3   max_bounces = 10000
               track_all_orders = true   sensor_resolution = 57 (N x N cells)
  [output]     path = "table.h5" (relative to the config file)

conventions: macro normal +z; theta from +z, phi from +x toward +y; directions
point away from the surface. The table holds, per incident direction, bounce
order (0 = all orders, f_inf) and sensor cell, the cell-averaged cosine-weighted
BRDF in 1/sr with its standard error (docs/hdf5-format.md).

without CONFIG: the built-in default run, the IL paper's figure 7(b) material
(Beckmann alpha 0.6, kd 0.9, eta 1.5) at theta_i = 0, 30, 60, 80 degrees.
examples in runs/. The same config and seed give the same table for any
--threads and --chunk-blocks.
"""


def run_epilog() -> str:
    """``vcavity run --help`` epilog: config keys, generated from the registries."""
    from vcavity.facet import registry as facets
    from vcavity.microfacet import registry as distributions

    lines = ["config file (TOML):",
             f"  [material]   distribution = {' | '.join(repr(n) for n in distributions.NAMES)} "
             f"(default 'beckmann'), with its parameters:"]
    lines += [f"      {line}" for line in distributions.help_lines()]
    lines.append(f"               facet = {' | '.join(repr(n) for n in facets.NAMES)} "
                 "(default 'interfaced_lambertian'), with its parameters:")
    lines += [f"      {line}" for line in facets.help_lines()]
    return "\n".join(lines) + "\n" + _RUN_EPILOG_TAIL


def _positive_int(text: str) -> int:
    try:
        value = int(text.replace("_", ""))
    except ValueError:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r}: expected a positive integer") from None
        if not (math.isfinite(value) and value == int(value)):
            raise argparse.ArgumentTypeError(f"{text!r}: expected a positive integer") from None
        value = int(value)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a positive integer")
    return value


def _nonnegative_int(text: str) -> int:
    if text == "0":
        return 0
    return _positive_int(text)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose epilog may be a function, called only when help is shown.

    ``vcavity run --help`` lists every registered distribution and facet model; building
    that text imports the registries (and Numba), which ``vcavity info`` must not need.
    """

    def __init__(self, *args, epilog_factory=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._epilog_factory = epilog_factory

    def format_help(self):
        if self._epilog_factory is not None:
            self.epilog = self._epilog_factory()
            self._epilog_factory = None
        return super().format_help()


def build_parser() -> argparse.ArgumentParser:
    """The ``vcavity`` argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="vcavity",
        description="Monte-Carlo simulation of light in microfacet V-cavities: "
        "BRDF tables per bounce order (f1, f2, ..., f_inf) with error bars.",
    )
    from vcavity import __version__

    parser.add_argument("--version", action="version", version=f"vcavity {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
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
                     help="output table (default: [output].path, else CONFIG with .h5, else ./vcavity-default.h5); "
                     "an existing file is replaced atomically when the run completes")
    run.add_argument("--paths", type=_positive_int, metavar="N", help="paths per incident direction (overrides the config)")
    run.add_argument("--threads", type=_positive_int, metavar="T", help="worker threads (default: all cores)")
    run.add_argument("--seed", type=_nonnegative_int, metavar="S", help="random seed (overrides the config)")
    run.add_argument("--chunk-blocks", type=_positive_int, metavar="B",
                     help="RNG blocks of 4096 paths per kernel call (default 512; does not change results)")
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
    compare.add_argument("--significance", type=float, default=0.01, metavar="A",
                         help="family-wise false-alarm rate of the chi-square tests (default 0.01)")
    compare.add_argument("--nodes", type=_positive_int, default=64, metavar="N",
                         help="body-integral nodes per axis of the model (accuracy control, default 64)")
    compare.add_argument("--lambda-fit", action="store_true",
                         help="Smith models on beckmann: Walter's rational Lambda instead of the exact erf form")
    return parser


def _error(message: str) -> int:
    print(f"vcavity: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _resolve_output(args, cfg) -> Path:
    if args.output:
        return Path(args.output)
    if cfg.output is not None:
        return cfg.output
    if args.config:
        return Path(args.config).with_suffix(".h5")
    return Path("vcavity-default.h5")


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
    except config_mod.ConfigError as exc:
        return _error(str(exc))
    out = _resolve_output(args, cfg)
    if out.exists() and out.is_dir():
        return _error(f"--output = {str(out)!r}: is a directory; give a file path")
    if not out.parent.is_dir():
        return _error(f"--output = {str(out)!r}: folder {str(out.parent)!r} does not exist")
    if not os.access(out.parent, os.W_OK):
        return _error(f"--output = {str(out)!r}: folder {str(out.parent)!r} is not writable")
    import numba

    if args.threads is not None and args.threads > numba.config.NUMBA_NUM_THREADS:
        return _error(f"--threads = {args.threads}: must be between 1 and {numba.config.NUMBA_NUM_THREADS} (cores here)")

    from vcavity.io.table import write_table
    from vcavity.report import format_summary
    from vcavity.simulate import Simulation

    sim = Simulation(cfg, threads=args.threads, chunk_blocks=args.chunk_blocks)
    print(f"vcavity: {cfg.source}: {len(cfg.incidence)} incident direction(s), "
          f"{sim.total_paths:,} paths, {sim.threads} thread(s)", file=sys.stderr)
    compile_s = sim.compile()
    print(f"vcavity: kernel ready in {compile_s:.2f} s (compile or cache load, not counted as run time)",
          file=sys.stderr)
    try:
        if args.quiet:
            result = sim.run()
        else:
            from tqdm import tqdm

            with tqdm(total=sim.total_paths, unit="path", unit_scale=True, dynamic_ncols=True,
                      desc="tracing", file=sys.stderr) as bar:
                result = sim.run(on_progress=bar.update)
    except KeyboardInterrupt:
        print("vcavity: interrupted; no table written", file=sys.stderr)
        return EXIT_INTERRUPTED
    cfg = dataclasses.replace(cfg, output=out.resolve())  # the table records where it was written
    write_table(
        out,
        theta_i=result.theta_i, phi_i=result.phi_i, order=result.order, counts=result.counts,
        theta_i_deg=[d.theta_i_deg for d in cfg.incidence], phi_i_deg=[d.phi_i_deg for d in cfg.incidence],
        paths=result.paths, absorbed_paths=result.absorbed_paths, truncated_paths=result.truncated_paths,
        degenerate_paths=result.degenerate_paths, max_bounces_seen=result.max_bounces_seen,
        sensor=result.sensor, material=cfg.material.to_dict(), config=cfg.to_dict(), seed=cfg.seed,
        block_size=_block_size(), max_bounces=cfg.effective_max_bounces,
        compute_time_s=result.compute_time_s, compile_time_s=result.compile_time_s,
    )
    rate = sim.total_paths / result.compute_time_s if result.compute_time_s > 0 else float("inf")
    print(f"wrote {out}")
    print(f"run time {result.compute_time_s:.2f} s ({rate / 1e6:.2f} M paths/s), "
          f"kernel compile/load {result.compile_time_s:.2f} s")
    from vcavity.io.table import open_table

    print(format_summary(open_table(out)))
    return EXIT_OK


def _block_size() -> int:
    from vcavity.rng import BLOCK_SIZE

    return BLOCK_SIZE


def _cmd_info(args) -> int:
    from vcavity.io.table import TableFormatError, open_table
    from vcavity.report import format_summary

    try:
        table = open_table(args.table)
    except FileNotFoundError:
        return _error(f"table {args.table!r}: no such file")
    except (TableFormatError, OSError) as exc:
        return _error(str(exc).splitlines()[0] if str(exc) else f"table {args.table!r}: cannot read it")
    print(format_summary(table, verbose=True))
    return EXIT_OK


def _cmd_compare(args) -> int:
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.compare import compare_table, format_report
    from vcavity.io.table import TableFormatError, open_table

    if not 0.0 < args.significance < 1.0:
        return _error(f"--significance = {args.significance}: must be in (0, 1)")
    try:
        table = open_table(args.table)
    except FileNotFoundError:
        return _error(f"table {args.table!r}: no such file")
    except (TableFormatError, OSError) as exc:
        return _error(str(exc).splitlines()[0] if str(exc) else f"table {args.table!r}: cannot read it")
    try:
        report = compare_table(table, model=args.model, significance=args.significance, n_nodes=args.nodes,
                               lambda_fit=args.lambda_fit, plots_dir=args.plots)
    except ModelNotApplicable as exc:
        return _error(str(exc).splitlines()[0])
    print(format_report(report))
    if args.plots:
        print(f"plots written to {args.plots}")
    return EXIT_OK if report.passed else 1


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``vcavity`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "run":
        return _cmd_run(args)
    if args.command == "info":
        return _cmd_info(args)
    if args.command == "compare":
        return _cmd_compare(args)
    parser.error(f"unknown command {args.command!r}")
    return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
