"""Exports of tables and sweeps to the formats renderers read (``vcavity export``).

One module per format, registered by one line in :data:`FORMAT_MODULES`. Every format
module offers the same interface:

``NAME`` : str
    The ``--format`` value.
``SOURCE`` : ``"table"`` or ``"sweep"``
    What it exports: a table of ``vcavity run`` or a sweep file of ``vcavity sweep``.
``SUFFIX`` : str
    The usual file suffix (used for the default output name).
``SUMMARY`` : str
    One line for ``vcavity export --help``.
``prepare(source, request) -> object``
    Every check and all computation: refuses a source the format cannot represent by
    raising :class:`ExportRefused` (one line: what is refused and why), before anything is
    written. Returns what ``write`` needs.
``write(prepared, path) -> None``
    Writes the file at ``path`` (a fresh temporary file that the caller renames onto the
    destination atomically; see :func:`export`).

Plain NumPy (tables are read through :mod:`vcavity.io`), except where a format evaluates the table's distribution: ``rgl``
(and ``rgl-spectral``, built on it) fits its sampling warp with the jitted registry
(:mod:`vcavity.microfacet.registry`, compiled or loaded from Numba's cache). No export
imports the walk (``vcavity.kernels``, ``vcavity.simulate``).
"""

from __future__ import annotations

import dataclasses
import importlib
from dataclasses import dataclass
from pathlib import Path

from vcavity.io.schema import orders_text

#: --format value -> module implementing it (the one place a format is registered)
FORMAT_MODULES = {
    "rgl": "vcavity.export.rgl",
    "rgl-spectral": "vcavity.export.rgl_spectral",
    "merl": "vcavity.export.merl",
    "albedo-lut": "vcavity.export.albedo_lut",
    "csv": "vcavity.export.csv_slice",
}


class ExportRefused(ValueError):
    """The source cannot be written in the requested format; the message is one line."""


@dataclass(frozen=True)
class ExportRequest:
    """What the user asked for, checked for syntax only (formats check the meaning).

    Attributes
    ----------
    order : int
        Bounce order: 0 = f_inf (all orders), k = exactly k bounces.
    order_text : str
        The order as the user wrote it (for messages).
    theta_i_deg : str or None
        ``--theta-i``: the incident polar angle of the slice (csv), degrees as in the run
        config; None: the format's default.
    output : pathlib.Path or None
        The destination as given (:func:`export` fills it in): formats whose container
        follows the file's suffix (albedo-lut: ``.npz`` or ``.h``) check it in ``prepare``,
        since ``write`` is handed a temporary file name.
    layout : str
        ``--layout`` (albedo-lut): ``"vcavity"`` (default) or ``"cycles"``.
    orders : tuple of int or None
        ``--orders`` (albedo-lut): the orders to tabulate (0 = f_inf), None: not given.
    orders_text : tuple of str
        The orders as the user wrote them (for messages).
    """

    order: int = 0
    order_text: str = "0"
    theta_i_deg: str | None = None
    output: Path | None = None
    layout: str = "vcavity"
    orders: tuple[int, ...] | None = None
    orders_text: tuple[str, ...] = ()


def header_text(text) -> str:
    """``text`` safe inside a one-line comment of a text file (CSV ``#`` lines, C headers).

    Control characters and line or paragraph separators (a file named ``new\\nline.h5``)
    are written as Python escapes (``\\n``, ``\\x1b``, ``\\u2028``), so no name breaks a
    comment line or shifts the line count a reader skips; every other character is kept.
    """
    import unicodedata

    return "".join(ch.encode("unicode_escape").decode("ascii")
                   if unicodedata.category(ch) in ("Cc", "Zl", "Zp") else ch for ch in str(text))


def format_module(name: str):
    """The module of format ``name``.

    Raises
    ------
    ExportRefused
        ``name`` is not a registered format (the message lists them).
    """
    if name not in FORMAT_MODULES:
        raise ExportRefused(f"--format = {name!r}: accepted formats are {', '.join(FORMAT_MODULES)}")
    return importlib.import_module(FORMAT_MODULES[name])


def order_data(table, request: ExportRequest):
    """The table's brdf of the requested order, shape (n_i, n_c), and its index.

    Raises
    ------
    ExportRefused
        The table has no such order (a table without f_inf, or K beyond its max order).
    """
    orders = [int(k) for k in table.order]
    if request.order not in orders:
        raise ExportRefused(f"--order = {request.order_text!r}: table {str(table.path)!r} has orders "
                            f"{orders_text(orders)}")
    index = orders.index(request.order)
    return table.brdf[:, index, :], index


def export(source, format_name: str, request: ExportRequest, path, cancelled=None) -> None:
    """Export ``source`` to ``path`` atomically: all checks first, then one rename.

    Parameters
    ----------
    source : vcavity.io.table.Table or vcavity.io.sweep_table.SweepData
    format_name : str
    request : ExportRequest
    path : str or os.PathLike
    cancelled : callable, optional
        Asked just before the rename (:func:`vcavity.io.atomic.replace_atomically`): True
        removes the complete temporary file and raises ``KeyboardInterrupt``.

    Raises
    ------
    ExportRefused
        Before anything is written; ``path`` is untouched. Also when the format asks the
        table API for an incident direction the table does not serve
        (:class:`~vcavity.brdf.incidence.DirectionNotTabulated`, one line), should a
        format's own checks have let such a table through.
    """
    from vcavity.brdf.incidence import DirectionNotTabulated
    from vcavity.io.atomic import replace_atomically

    module = format_module(format_name)
    if request.output is None:
        request = dataclasses.replace(request, output=Path(path))
    try:
        prepared = module.prepare(source, request)
    except DirectionNotTabulated as exc:
        raise ExportRefused(f"--format {format_name}: {str(exc).splitlines()[0]}") from None
    replace_atomically(Path(path), lambda temporary: module.write(prepared, Path(temporary)), cancelled=cancelled)
