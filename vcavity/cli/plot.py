"""``vcavity plot``: draw a table or a sweep file.

Exit status: 0 written; 2 bad input (unknown kind, an order or theta_i the source lacks,
an unusable output path), one line, reported before anything is computed, or the image
could not be written (a full disk: one line, nothing written); 130 interrupted.
"""

from __future__ import annotations

import argparse

from vcavity.cli.common import EXIT_BAD_INPUT, EXIT_OK, error, open_table_or_error, written

NAME = "plot"

_PLOT_EPILOG = """\
kinds:
  slice   in-plane slices (plane of incidence; theta_o signed, > 0 on the specular
          side phi_o = phi_i + 180, < 0 toward the light phi_o = phi_i) of f1, f2 and
          f_inf on a log scale: one step per sensor cell the plane crosses (a table
          holds cell averages), bands of +-2 standard errors, and the V-cavity and
          Smith single-bounce models of f1 averaged over the same cells
  map     equal-area hemispherical maps (disk, rings at theta_o = 30, 60, 90 deg) of
          every order side by side, one row per incident direction; colour bars in 1/sr
  albedo  albedo per order against theta_i, and the inter-reflection share
          (f_inf - f1) / f_inf (needs f_inf: track_all_orders = true)
  sweep   a sweep file (vcavity sweep; the default kind for one): albedo of f1 and
          f_inf (--order for others) against the roughness axis (alpha, alpha_x,
          alpha_y, sigma or exponent), one colour per combination of the other
          material axes (eta, kd, ...), one panel per theta_i, error bars +-2
          standard errors; slice, map and albedo draw a table of vcavity run
  versus  two tables of one material (the default kind for two inputs; the microsurface
          may differ, anything else only with --force), or two points of a sweep file
          (--point AXIS=VALUE for every other point axis of several values; --versus AXIS
          or AXIS=A,B, default microsurface): albedo per order against theta_i of A and B,
          in-plane slices of f1, f2, f_inf of both per theta_i, and under each B - A with
          bands of +-2 sigma (sigma = quadrature sum of both standard errors)

examples:
  vcavity plot t.h5                                  # slices of every direction -> t_slice.png
  vcavity plot t.h5 --kind map --theta-i 60 --scale log -o map60.png
  vcavity plot t.h5 --kind slice --order 1 3 inf --theta-i 30 60
  vcavity plot t.h5 --kind albedo -o albedo.pdf
  vcavity plot s.h5 --theta-i 45 --order 1 2 inf     # a sweep file -> s_sweep.png
  vcavity plot vcav.h5 smith.h5 --theta-i 60          # A vs B -> vcav_versus.png
  vcavity plot s.h5 --kind versus --point alpha=0.6   # microsurface v-cavity vs smith at alpha 0.6
scripts/fig7.py draws the IL paper's figure 7 from runs/fig7_eta1.0.toml and fig7_eta1.5.toml.
"""


def add_parser(subparsers) -> None:
    """Add the ``plot`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    plot = subparsers.add_parser(
        NAME, help="draw a table (in-plane slices, hemispherical maps, albedos), a sweep file "
        "(albedo against roughness) or two tables side by side (versus) (PNG, PDF, SVG)",
        description="Draw a table or a sweep file with matplotlib: BRDF values in 1/sr, angles in "
        "degrees. Bad input (unknown kind, an order or theta_i the table lacks, -o in a missing "
        "folder, an existing file without --overwrite, a link, FIFO or the input itself) is a one-line "
        "error with exit status 2, reported before anything is computed; the image is written atomically "
        "(a write that fails, e.g. on a full disk, is one line, exit status 2, and leaves nothing behind).",
        epilog=_PLOT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    plot.set_defaults(handler=command)
    plot.add_argument("table", metavar="TABLE.h5", nargs="+", help="a table written by vcavity run, or a "
                      "sweep file written by vcavity sweep; two tables for --kind versus")
    plot.add_argument("--kind", metavar="KIND",
                      help="slice (default for a table), map, albedo; sweep (default for a sweep file); "
                      "versus (default for two tables) (see below)")
    plot.add_argument("-o", "--output", metavar="FILE",
                      help="image to write, .png, .pdf or .svg (default: <table>_<kind>.png beside the table)")
    plot.add_argument("--overwrite", action="store_true",
                      help="replace an existing image (atomically); links, FIFOs, folders and the input "
                      "itself never are")
    plot.add_argument("--theta-i", nargs="+", metavar="DEG",
                      help="incident polar angles to draw, degrees as in the run config (default: all)")
    plot.add_argument("--order", nargs="+", metavar="K",
                      help="bounce orders: 1 2 ... (or f1 f2 ...), 0 / inf / f_inf for all orders "
                      "(default: slice f1 f2 f_inf, map and albedo every order of the table, sweep f1 f_inf)")
    plot.add_argument("--scale", metavar="SCALE",
                      help="log or linear value scale of slices and maps (default: slice log, map linear)")
    plot.add_argument("--no-models", action="store_true",
                      help="slice: leave out the analytic models (they compile Numba code on first use)")
    plot.add_argument("--point", nargs="+", metavar="AXIS=VALUE",
                      help="versus of a sweep file: the point, a value of each point axis but the compared one")
    plot.add_argument("--versus", metavar="AXIS[=A,B]",
                      help="versus of a sweep file: the axis compared, with its two values unless it has "
                      "exactly two (default microsurface)")
    plot.add_argument("--force", action="store_true",
                      help="versus: draw two tables whose materials differ in more than the microsurface")


def command(args: argparse.Namespace) -> int:
    """``vcavity plot TABLE.h5 [--kind KIND] [-o FILE] ...``: a table or a sweep file.

    Returns the exit status (:mod:`vcavity.cli.common`).
    """
    from vcavity.plots import PlotError, check_request, render
    from vcavity.plots.request import ImageNotWritten

    if len(args.table) > 2:
        return error(f"inputs = {' '.join(args.table)}: at most two (two tables for --kind versus)")
    sources = []
    for path in args.table:  # tables or sweep files; the first unreadable one is the error
        sources.append(open_table_or_error(path, sweeps=True))
        if sources[-1] is None:
            return EXIT_BAD_INPUT
    try:
        request = check_request(sources[0], kind=args.kind, output=args.output, theta_i_deg=args.theta_i,
                                orders=args.order, scale=args.scale, models=not args.no_models,
                                overwrite=args.overwrite, second=sources[1] if len(sources) > 1 else None,
                                points=args.point, versus=args.versus, force=args.force)
    except PlotError as exc:
        return error(str(exc))
    from vcavity.simulate.interrupts import DeferredInterrupt

    # as export: a Ctrl-C before the rename cancels it, one from the rename on names the file
    with DeferredInterrupt() as interrupt:
        try:
            render(sources[0], request, cancelled=interrupt.cancelled)
        except ImageNotWritten as exc:  # as export says it: one line, exit 2
            field, shown = ("-o", args.output) if args.output is not None else ("output", str(request.output))
            return error(f"{field} = {shown!r}: writing failed ({exc.reason}); nothing was written")
        written(request.output)
    interrupt.check()
    print(f"wrote {request.output}")
    return EXIT_OK
