"""Figure 7 of the IL paper (Meneveaux et al., interfaced Lambertian microfacets) from vcavity runs.

In-plane BRDF slices of Beckmann V-cavities (alpha = 0.6, kd = 0.9) with (a) Lambertian
facets (eta = 1.0) and (b) interfaced Lambertian facets (eta = 1.5): the simulated f1, f2
and f_inf with ±2 standard-error bands, and the single-bounce V-cavity and Smith models
of f1 averaged over the same sensor cells (``vcavity plot --kind slice``, whose data and
drawing this script reuses). One column per material, one row per incident angle.

    python scripts/fig7.py                       # runs/fig7_eta1.0.h5, runs/fig7_eta1.5.h5 -> fig7.png
    python scripts/fig7.py a.h5 b.h5 -o fig7.pdf --theta-i 30 60
    python scripts/fig7.py --paths 2e6           # run the configs with fewer paths if a table is missing

Tables given on the command line are used as they are. Without tables, the script uses
``runs/fig7_eta1.0.h5`` and ``runs/fig7_eta1.5.h5`` (where ``vcavity run`` writes them
for those configs) and runs a config whose table is missing (``--paths`` overrides the
configs' 10^8 paths per direction, about 20 s per material at 24 M paths/s on 2 cores).
Exit status 2 with a one-line message for bad input, before anything is run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = (ROOT / "runs" / "fig7_eta1.0.toml", ROOT / "runs" / "fig7_eta1.5.toml")


def _parser():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__.split("\n\n", 1)[1])
    parser.add_argument("tables", nargs="*", metavar="TABLE.h5",
                        help="tables to draw, one panel column each (default: the two fig7 runs)")
    parser.add_argument("-o", "--output", default="fig7.png", metavar="FILE",
                        help="image to write, .png, .pdf or .svg (default fig7.png)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing image (atomically)")
    parser.add_argument("--theta-i", nargs="+", metavar="DEG",
                        help="incident angles, one row each (default: every theta_i of the first table)")
    parser.add_argument("--order", nargs="+", metavar="K", default=["1", "2", "inf"],
                        help="orders to draw (default: 1 2 inf)")
    parser.add_argument("--paths", metavar="N", help="paths per direction when running a missing table")
    parser.add_argument("--no-models", action="store_true", help="leave out the analytic models")
    return parser


def _error(message):
    print(f"fig7: error: {message}", file=sys.stderr)
    return 2


def _ensure_tables(args):
    """The tables to draw: given ones, or the fig7 runs (run when missing)."""
    if args.tables:
        return [Path(t) for t in args.tables]
    from vcavity.cli import main as vcavity_main

    tables = []
    for config in CONFIGS:
        table = config.with_suffix(".h5")
        if not table.exists():
            command = ["run", str(config), "-o", str(table), "-q"]
            if args.paths:
                command += ["--paths", args.paths]
            status = vcavity_main(command)
            if status != 0:
                raise SystemExit(status)
        tables.append(table)
    return tables


def main(argv=None) -> int:
    """Draw the figure; returns the exit status."""
    args = _parser().parse_args(argv)
    from matplotlib.figure import Figure

    from vcavity.io.table import TableFormatError, open_table
    from vcavity.plots import PlotError, check_output, check_request, parse_order, save
    from vcavity.plots import data as plot_data
    from vcavity.plots import figures
    from vcavity.io.summary import format_material

    try:  # what can be checked before running anything
        output = check_output(args.output, args.overwrite)
        for k in args.order:
            parse_order(k)
        for t in args.theta_i or ():
            float(t)
    except PlotError as exc:
        return _error(str(exc))
    except ValueError:
        return _error(f"--theta-i = {' '.join(args.theta_i)!r}: expected angles in degrees")
    paths = _ensure_tables(args)
    try:
        tables = [open_table(p) for p in paths]
    except FileNotFoundError as exc:
        return _error(f"table {exc.filename!r}: no such file")
    except TableFormatError as exc:
        return _error(str(exc))
    theta = args.theta_i or [f"{t:g}" for t in tables[0].theta_i_deg]
    try:
        requests = [check_request(t, "slice", output, theta_i_deg=theta, orders=args.order,
                                  models=not args.no_models, overwrite=args.overwrite) for t in tables]
    except PlotError as exc:
        return _error(str(exc))

    rows, columns = len(requests[0].indices), len(tables)
    fig = Figure(figsize=(5.2 * columns, 3.6 * rows + 1.2), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False)
    for c, (table, request) in enumerate(zip(tables, requests)):
        models, notes = plot_data.build_models(table, request.models)
        eta = table.material.get("eta")
        label = f"({chr(ord('a') + c)}) " + (f"eta = {eta:g}" if eta is not None else table.path.stem)
        for r, j in enumerate(request.indices):
            data = plot_data.slice_data(table, j, request.orders, models, notes)
            figures.draw_slice(axes[r, c], data, title=f"{label}, theta_i = {data.theta_i_deg:g}°")
    figures.figure_legend(fig, axes[0, 0])
    materials = "; ".join(f"({chr(ord('a') + c)}) {format_material(t.material)}"
                          for c, t in enumerate(tables))
    fig.suptitle(f"IL paper figure 7 from vcavity tables: in-plane slices\n{materials}", fontsize=10)
    save(fig, output)
    print(f"wrote {output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
