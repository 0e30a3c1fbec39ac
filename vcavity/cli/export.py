"""``vcavity export``: a table (or a sweep) in a format renderers read.

Exit status: 0 written; 2 bad input or a source the format cannot represent (one line, the
output untouched, no file left behind); 130 interrupted.
"""

from __future__ import annotations

import argparse

from vcavity.cli.common import EXIT_OK, error, first_line, written

NAME = "export"


def _epilog() -> str:
    from vcavity.export import FORMAT_MODULES, format_module

    lines = ["formats:"]
    for name in FORMAT_MODULES:
        module = format_module(name)
        lines.append(f"  {name:<13} {module.SUMMARY} (from a {module.SOURCE})")
    lines += [
        "",
        "--order K picks the bounce order of every format: 0 (default) = f_inf, all orders;",
        "K = light that left after exactly K bounces. The output is written atomically and an",
        "existing file is replaced only with --overwrite. Formats and their conventions:",
        "docs/exports.md.",
        "",
        "albedo-lut: --layout cycles writes Blender Cycles' table_ggx_E / table_ggx_Eavg layout",
        "(32 x 32 nodes r = sqrt(alpha) = i/31, mu = cos(theta_i) = i/31, clamped to 1e-4;",
        "E[mu * 32 + r]; the sweep: runs/sweep_albedo_lut_cycles.toml). --orders 1 2 3 inf",
        "writes E of each order listed and E_rest = E(f_inf) minus the listed finite orders.",
    ]
    return "\n".join(lines)


def add_parser(subparsers) -> None:
    """Add the ``export`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    export = subparsers.add_parser(
        NAME, help="write a table in a renderer's format (RGL .bsdf, MERL, albedo LUT, CSV)",
        description="Convert a table of `vcavity run` (or, for albedo-lut, a sweep file of "
        "`vcavity sweep`) into a file another program reads. Every check runs before anything "
        "is written; a table the format cannot represent is refused in one line (exit 2).",
        epilog_factory=_epilog, formatter_class=argparse.RawDescriptionHelpFormatter)
    export.set_defaults(handler=command)
    export.add_argument("table", metavar="IN.h5", help="a table (vcavity run) or a sweep file (vcavity sweep)")
    export.add_argument("output", metavar="FILE", help="the file to write")
    export.add_argument("--format", required=True, metavar="FORMAT",
                        help="rgl, rgl-spectral, merl, albedo-lut or csv (see below)")
    export.add_argument("--order", default="0", metavar="K",
                        help="bounce order: 0 / inf / f_inf (default, all orders), 1 / f1, 2 / f2, ...")
    export.add_argument("--theta-i", metavar="DEG",
                        help="csv: the incident polar angle of the slice, degrees as in the run config "
                        "(default: the table's only one; required when it has several)")
    export.add_argument("--layout", choices=("vcavity", "cycles"),
                        help="albedo-lut: vcavity (default: mu at the midpoints of equal bins, E[alpha][mu]) or "
                        "cycles (Blender Cycles' 32 x 32 node grids of r = sqrt(alpha) and mu, E[mu * 32 + r]; "
                        ".npz, .npy or .h)")
    export.add_argument("--orders", nargs="+", metavar="K",
                        help="albedo-lut: the orders to tabulate, e.g. 1 2 3 inf: E_f1, E_f2, E_f3, E (f_inf) and "
                        "E_rest = E minus the listed finite orders (instead of E_f1 and the --order)")
    export.add_argument("--overwrite", action="store_true", help="replace an existing FILE")


def command(args: argparse.Namespace) -> int:
    """``vcavity export IN.h5 FILE --format F [--order K] [--overwrite]``.

    Returns the exit status (:mod:`vcavity.cli.common`).
    """
    import os
    from pathlib import Path

    from vcavity.io import preflight
    from vcavity.export import ExportRefused, ExportRequest, export, format_module
    from vcavity.io.sweep_table import is_sweep_file
    from vcavity.plots import PlotError, parse_order
    from vcavity.io.schema import order_name

    try:
        module = format_module(args.format)
    except ExportRefused as exc:
        return error(str(exc))
    try:
        order = parse_order(args.order)
    except PlotError:
        return error(f"--order = {args.order!r}: accepted are 0, inf or f_inf (all orders) and 1, 2, ... "
                      "(or f1, f2, ...)")
    if args.theta_i is not None and args.format != "csv":
        return error(f"--theta-i = {args.theta_i!r}: only --format csv takes an incident angle "
                      f"(--format {args.format} exports every incident direction)")
    for flag, given in (("--layout", args.layout), ("--orders", args.orders)):
        if given is not None and args.format != "albedo-lut":
            return error(f"{flag} = {given if isinstance(given, str) else ' '.join(given)!r}: only --format "
                         "albedo-lut takes it")
    orders = None
    if args.orders is not None:
        if args.order != "0":
            return error(f"--orders with --order = {args.order!r}: give one (--orders lists every order to write)")
        try:
            orders = tuple(parse_order(k) for k in args.orders)
        except PlotError:
            return error(f"--orders = {' '.join(args.orders)!r}: accepted are orders 1, 2, ... (or f1, f2, ...) "
                         "and inf (f_inf, 0)")
        repeated = sorted({k for k in orders if orders.count(k) > 1})
        if repeated:
            return error(f"--orders = {' '.join(args.orders)!r}: lists {order_name(repeated[0])} twice; each "
                         "order once")
    source_path = Path(args.table)
    if not source_path.exists():
        return error(f"table {args.table!r}: no such file")
    if not source_path.is_file():
        return error(f"table {args.table!r}: not a regular file")
    example = f"'out{module.SUFFIX}'"
    if args.output == "" or args.output.endswith(("/", os.sep)) or Path(args.output).name in ("", ".", ".."):
        return error(f"FILE = {args.output!r}: must name a file, such as {example}")
    out = preflight.Output(Path(args.output), "FILE", args.output)
    try:
        preflight.check_output(out, None, args.overwrite, source=args.table)
        preflight.probe_output(out)
    except preflight.PreflightError as exc:
        return error(str(exc))
    try:
        source = _open_source(source_path, args.table, module, is_sweep_file(source_path))
    except ExportRefused as exc:
        return error(str(exc))
    request = ExportRequest(order=order, order_text=args.order, theta_i_deg=args.theta_i,
                            layout=args.layout or "vcavity", orders=orders, orders_text=tuple(args.orders or ()))
    from vcavity.simulate.interrupts import DeferredInterrupt

    # Ctrl-C deferred: before the rename it cancels the write (nothing written); from the
    # rename on it is acted on once the file is recorded as written, so its line names it
    with DeferredInterrupt() as interrupt:
        try:
            export(source, args.format, request, out.path, cancelled=interrupt.cancelled)
        except ExportRefused as exc:
            return error(str(exc))
        except OSError as exc:
            return error(f"FILE = {out.shown!r}: writing failed ({exc.strerror or exc}); nothing was written")
        written(out.path)
    interrupt.check()
    what = order_name(order) if orders is None else ", ".join(order_name(k) for k in orders)
    layout = f", layout {args.layout}" if args.layout is not None else ""
    print(f"wrote {out.path} ({args.format}{layout}, {what})")
    return EXIT_OK


def _open_source(path, shown: str, module, is_sweep: bool):
    """The table or sweep ``module`` exports; refuses the other kind in one line."""
    from vcavity.export import ExportRefused
    from vcavity.io.table import TableFormatError, open_table

    if module.SOURCE == "sweep":
        if not is_sweep:
            raise ExportRefused(f"table {shown!r}: --format {module.NAME} exports a sweep file "
                                "(vcavity sweep), this is a table of one run")
        from vcavity.io.sweep_table import open_sweep

        try:
            return open_sweep(path)
        except TableFormatError as exc:  # its one line names the file and the dataset
            raise ExportRefused(first_line(exc)) from None
        except (ValueError, OSError, KeyError) as exc:
            raise ExportRefused(f"sweep {shown!r}: cannot read it ({first_line(exc)})") from None
    if is_sweep:
        raise ExportRefused(f"table {shown!r}: is a sweep file; --format {module.NAME} exports a table "
                            "of one run (vcavity run)")
    try:
        return open_table(path)
    except (TableFormatError, OSError) as exc:
        raise ExportRefused(first_line(exc)) from None
