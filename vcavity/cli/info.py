"""``vcavity info``: a human summary of a table, a sweep file or a run's checkpoint.

Exit status: 0 printed; 2 a file that is none of these, or unreadable (one line).
"""

from __future__ import annotations

import argparse

from vcavity.cli.common import EXIT_BAD_INPUT, EXIT_OK, error, first_line, open_table_or_error

NAME = "info"


def add_parser(subparsers) -> None:
    """Add the ``info`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    info = subparsers.add_parser(
        NAME, help="print a human summary of a table",
        description="Print the material, budget, albedo per order, absorbed and truncated energy of a table.")
    info.set_defaults(handler=command)
    info.add_argument("table", metavar="TABLE.h5")


def command(args: argparse.Namespace) -> int:
    """``vcavity info TABLE.h5``: the summary of a table, a sweep file or a checkpoint.

    Returns the exit status (:mod:`vcavity.cli.common`).
    """
    from pathlib import Path

    from vcavity.io import checkpoint
    from vcavity.io.sweep_table import is_sweep_file

    # what the file is, asked of regular files only: h5py blocks on a FIFO
    if Path(args.table).is_file() and is_sweep_file(args.table):
        return _sweep_info(args.table)
    if Path(args.table).is_file() and checkpoint.is_checkpoint(args.table):
        return _checkpoint_info(args.table)
    from vcavity.io.summary import format_summary

    table = open_table_or_error(args.table)
    if table is None:
        return EXIT_BAD_INPUT
    print(format_summary(table, verbose=True))
    return EXIT_OK


def _sweep_info(path: str) -> int:
    """The summary of a sweep file (``vcavity sweep``)."""
    from vcavity.io.sweep_summary import format_sweep_summary
    from vcavity.io.sweep_table import SweepFormatError, open_sweep

    try:
        sweep = open_sweep(path)
    except (FileNotFoundError, SweepFormatError) as exc:
        return error(str(exc))
    print(format_sweep_summary(sweep))
    return EXIT_OK


def _checkpoint_info(path: str) -> int:
    """What an interrupted run's checkpoint holds, and how to continue it."""
    from vcavity.io.summary import describe_checkpoint

    try:
        print(describe_checkpoint(path))
    except (OSError, KeyError, ValueError) as exc:
        return error(f"checkpoint {path!r}: cannot read it ({first_line(exc, '')})")
    return EXIT_OK
