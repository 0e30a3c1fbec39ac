"""``vcavity compare``: test a table against an analytic model.

Exit status: 0 the chi-square test of f1 passed for every incident direction; 1 it
failed; 2 bad input (not a table, missing dataset or order, model not applicable,
``--plots`` in a missing folder) or the plots could not be written (a full disk: none
is written), one line; 130 interrupted.
"""

from __future__ import annotations

import argparse

from vcavity.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_OK,
    EXIT_TEST_FAILED,
    count_arg,
    error,
    first_line,
    fraction_arg,
    open_table_or_error,
)

NAME = "compare"


def add_parser(subparsers) -> None:
    """Add the ``compare`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    compare = subparsers.add_parser(
        NAME, help="compare a table with an analytic model (exit 0 pass, 1 fail)",
        description="Compare a table with an analytic model: albedos, relative L1 over the "
        "hemisphere (with the value noise alone gives), and a Pearson chi-square test of the f1 "
        "counts against the V-cavity single-bounce model, its exact expectation. Exit status 0 "
        "when that test passes for every incident direction (Sidak-corrected), 1 when it fails, "
        "2 for bad input (not a table, missing dataset or order, model not applicable).")
    compare.set_defaults(handler=command)
    compare.add_argument("table", metavar="TABLE.h5")
    compare.add_argument("--model", default=None, choices=("vcavity", "smith", "smith-hc", "oren-nayar"),
                         help="model for albedo and L1: single-bounce with V-cavity, Smith separable or "
                         "height-correlated G2 (vs f1), or Oren-Nayar (vs f1 + f2; gaussian, eta = 1). "
                         "Default: the exact f1 model of the table's microsurface (vcavity; smith-hc for "
                         "microsurface = smith). The chi-square and albedo tests always use that exact model; "
                         "a V-cavity model on a Smith table is refused")
    compare.add_argument("--plots", metavar="DIR",
                         help="write one comparison PNG per incident direction to DIR (created if missing; the "
                         "folder above it must exist); if they cannot all be written (a full disk), none is: "
                         "one line, exit status 2")
    compare.add_argument("--significance", type=fraction_arg, default=0.01, metavar="A",
                         help="family-wise false-alarm rate of the chi-square tests (default 0.01)")
    compare.add_argument("--nodes", type=count_arg(1, 1024), default=64, metavar="N",
                         help="body-integral nodes per axis of the model (accuracy control, default 64, "
                         "at most 1024: the cost grows as N^2 per cell)")
    compare.add_argument("--lambda-fit", action="store_true",
                         help="Smith models on beckmann: Walter's rational Lambda instead of the exact erf form")
    compare.add_argument("--order", type=_order_arg, metavar="K",
                         help="test bounce order K (1, 2, 3, ... or inf) of a specular table (mirror, conductor, "
                         "kd = 0 dielectric) against the every-order model (deterministic, physics.md sec. 12-13): "
                         "chi-square over cells and albedo z-test; other facets: 'not applicable', exit 2")


def _order_arg(text: str) -> int:
    """``--order``: a bounce order >= 1, or ``inf`` (0, f_inf)."""
    if text.strip().lower() in ("inf", "f_inf", "0"):
        return 0
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: accepted a bounce order 1, 2, 3, ... or inf")
    return value


def command(args: argparse.Namespace) -> int:
    """``vcavity compare TABLE.h5 [--model M] [--plots DIR] ...``: print the report.

    Returns
    -------
    int
        :data:`EXIT_OK` when the test passed, :data:`EXIT_TEST_FAILED` when it failed,
        :data:`EXIT_BAD_INPUT` for bad input.
    """
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from pathlib import Path

    from vcavity.compare import PlotsNotWritten, compare_table, format_report
    from vcavity.io.preflight import PreflightError, check_plots_folder

    if not 0.0 < args.significance < 1.0:
        return error(f"--significance = {args.significance}: must be in (0, 1)")
    if args.plots is not None:
        try:
            folder = check_plots_folder(args.plots)
        except PreflightError as exc:
            return error(str(exc))
        if not folder.exists() and not folder.parent.is_dir():  # as plot -o: no folder tree made up
            return error(f"--plots = {args.plots!r}: folder {str(folder.parent)!r} does not exist; compare "
                         f"creates only {Path(args.plots).name!r} itself")
    table = open_table_or_error(args.table)
    if table is None:
        return EXIT_BAD_INPUT
    if args.order is not None:
        return _compare_order(args, table)
    if 1 in table.order and table.is_analytic(1):
        return error(f"table {args.table!r}: f1 is analytic in this table (estimator {table.estimator}), "
                     "there is no simulated f1 to test; run with --estimator analog to validate the walk")
    try:
        report = compare_table(table, model=args.model, significance=args.significance, n_nodes=args.nodes,
                               lambda_fit=args.lambda_fit, plots_dir=args.plots)
    except ModelNotApplicable as exc:
        return error(first_line(exc))
    except PlotsNotWritten as exc:  # not exit 1: that says the chi-square test failed
        return error(f"--plots = {args.plots!r}: writing the plots failed ({exc.reason}); nothing was written")
    print(format_report(report))
    if args.plots:
        print(f"plots written to {args.plots}")
    return EXIT_OK if report.passed else EXIT_TEST_FAILED


def _compare_order(args: argparse.Namespace, table) -> int:
    """``--order K``: the every-order model of specular tables (other options do not apply)."""
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.compare import compare_order, format_order_report

    # each flag's own reason: what it does without --order, and why --order has no use for it
    reasons = (("--model", args.model is not None, "the every-order model is the only model of --order; the "
                "single-bounce models of --model compare f1, without --order"),
               ("--plots", args.plots is not None, "--order draws no plots: its report is the chi-square over "
                "cells and the albedo z-test, as text; --plots draws the f1 comparison, without --order"),
               ("--lambda-fit", args.lambda_fit, "Walter's rational Lambda is a choice of the Smith models of "
                "f1; the every-order model traces V-grooves, it has no Lambda"),
               ("--nodes", args.nodes != 64, "--nodes is the single-bounce models' body-integral accuracy; the "
                "every-order model refines its own mesh to a tenth of the table's noise"))
    for flag, given, reason in reasons:
        if given:
            return error(f"{flag} does not apply with --order: {reason}")
    try:
        report = compare_order(table, args.order, significance=args.significance)
    except ModelNotApplicable as exc:
        return error(first_line(exc))
    print(format_order_report(report))
    return EXIT_OK if report.passed else EXIT_TEST_FAILED
