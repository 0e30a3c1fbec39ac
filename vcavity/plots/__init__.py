"""Plots of vcavity tables (``vcavity plot``): slices, hemispherical maps, albedos.

``plot_table(table, kind, output, ...)`` checks the request (:func:`check_request`,
one-line :class:`PlotError` before anything is computed), draws and saves the figure,
and returns the numbers it plotted, so tests and scripts can check them without
reading pixels:

- ``"slice"``: in-plane slices (plane of incidence, signed theta_o from -90 to 90 deg)
  of f1, f2 and f_inf by default, on a log scale, with ±2 standard-error bands and the
  V-cavity and Smith single-bounce models of f1 averaged over the same cells
  (:mod:`vcavity.plots.data`, :mod:`vcavity.plots.geometry`). Returns a list of
  :class:`~vcavity.plots.data.SliceData`, one per incident direction.
- ``"map"``: equal-area hemispherical maps of each order side by side, one row per
  incident direction. Returns ``{(incidence index, order): (N, N) values}``.
- ``"albedo"``: albedo per order against theta_i and the inter-reflection share
  ``(f_inf - f1)/f_inf``. Returns :class:`~vcavity.plots.data.AlbedoData`.
- ``"sweep"``: of a sweep file (``vcavity sweep``; the default kind for one): albedo of
  f1 and f_inf against the roughness axis, one line per combination of the other material
  axes, one panel per theta_i (:mod:`vcavity.plots.sweep`). Returns
  :class:`~vcavity.plots.sweep.SweepPlotData`. The other kinds draw a table of one run.

Only ``"slice"`` with models imports the analytic package (and Numba).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

KINDS = ("slice", "map", "albedo", "sweep")
SCALES = ("log", "linear")
DEFAULT_SCALE = {"slice": "log", "map": "linear", "albedo": "linear"}
#: Orders drawn when none are asked for; "all" = every order of the table.
DEFAULT_ORDERS = {"slice": (1, 2, 0), "map": "all", "albedo": "all"}
OUTPUT_SUFFIXES = (".png", ".pdf", ".svg")


class PlotError(ValueError):
    """A plot request the table cannot satisfy; the message is one line."""


@dataclass(frozen=True)
class PlotRequest:
    """A checked request: what :func:`render` draws."""

    kind: str
    output: Path
    indices: tuple
    orders: tuple
    scale: str
    models: tuple


def parse_order(text) -> int:
    """Bounce order from ``"0"``, ``"inf"``, ``"f_inf"``, ``"2"`` or ``"f2"``.

    Raises
    ------
    PlotError
        If ``text`` names no order.
    """
    word = str(text).strip().lower()
    if word in ("inf", "f_inf", "finf", "0"):
        return 0
    digits = word[1:] if word.startswith("f") else word
    if digits.isdigit():
        return int(digits)
    raise PlotError(f"--order = {text!r}: expected a bounce order: 1, 2, ... (or f1, f2, ...), "
                    "or 0 / inf / f_inf for all orders")


def _orders_text(table):
    return ", ".join("0 (f_inf)" if int(k) == 0 else str(int(k)) for k in table.order)


def default_output(table, kind: str) -> Path:
    """``<table stem>_<kind>.png`` beside the table."""
    return table.path.with_name(f"{table.path.stem}_{kind}.png")


def check_output(output) -> Path:
    """The output file as a path, refused (PlotError) unless it can be written."""
    out = Path(output)
    if out.suffix.lower() not in OUTPUT_SUFFIXES:
        raise PlotError(f"-o = {str(out)!r}: unsupported file type {out.suffix or '(none)'!r}; "
                        f"accepted {', '.join(OUTPUT_SUFFIXES)}")
    if out.is_dir():
        raise PlotError(f"-o = {str(out)!r}: is a directory; give a file path")
    folder = out.parent
    if not folder.is_dir():
        raise PlotError(f"-o = {str(out)!r}: folder {str(folder)!r} does not exist")
    if not os.access(folder, os.W_OK):
        raise PlotError(f"-o = {str(out)!r}: folder {str(folder)!r} is not writable")
    return out


def _is_sweep(source) -> bool:
    from vcavity.io.sweep_table import SweepData

    return isinstance(source, SweepData)


def select_theta(theta_deg, requested, source: str) -> list:
    """Indices of the incident directions ``--theta-i`` names (all when ``requested`` is empty).

    ``requested`` holds strings or numbers in degrees, matched within 1e-6 deg of the
    tabulated ``theta_deg`` (every direction at a matching angle, in order, once).

    Raises
    ------
    PlotError
        A value that is not a number or matches no tabulated angle (``source`` names the
        file in the message, which lists the tabulated angles).
    """
    theta = np.asarray(theta_deg, dtype=np.float64)
    if not requested:
        return list(range(theta.size))
    indices = []
    for value in requested:
        try:
            number = float(value)
        except ValueError:
            raise PlotError(f"--theta-i = {value!r}: expected an angle in degrees") from None
        hits = np.flatnonzero(np.isclose(theta, number, rtol=0.0, atol=1e-6))
        if hits.size == 0:
            listed = ", ".join(f"{t:g}" for t in theta)
            raise PlotError(f"--theta-i = {number:g}: not an incident direction of {source} "
                            f"(theta_i_deg: {listed})")
        indices.extend(int(h) for h in hits if int(h) not in indices)
    return indices


def check_request(table, kind: str | None = None, output=None, theta_i_deg=None, orders=None,
                  scale: str | None = None, models: bool = True) -> PlotRequest:
    """Check a plot request against a table (or a sweep) without computing anything.

    Parameters
    ----------
    table : vcavity.io.table.Table or vcavity.io.sweep_table.SweepData
        A sweep takes ``kind = "sweep"`` only (:func:`vcavity.plots.sweep.check_sweep_request`),
        a table every other kind.
    kind : str, optional
        One of :data:`KINDS`; default ``"sweep"`` for a sweep, ``"slice"`` for a table.
    output : path, optional
        Default :func:`default_output`.
    theta_i_deg : sequence of float or str, optional
        Incident polar angles (deg, as in the run config) to draw; default all. Every
        direction with that theta_i is drawn (whatever its phi_i).
    orders : sequence of int or str, optional
        Orders (:func:`parse_order`); default :data:`DEFAULT_ORDERS` present in the table.
    scale : {"log", "linear"}, optional
        Value axis of slices and colour scale of maps; default :data:`DEFAULT_SCALE`.
    models : bool
        Slices: overlay the single-bounce models of f1.

    Returns
    -------
    PlotRequest

    Raises
    ------
    PlotError
        One line naming the option, the value and what is accepted.
    """
    sweep = _is_sweep(table)
    if kind is None:
        kind = "sweep" if sweep else "slice"
    if kind not in KINDS:
        raise PlotError(f"--kind = {kind!r}: accepted {', '.join(KINDS)}")
    if sweep:
        if kind != "sweep":
            raise PlotError(f"--kind = {kind!r}: {table.path.name if table.path else 'this'} is a sweep file "
                            "(vcavity sweep), drawn with --kind sweep (albedo against roughness); slice, map "
                            "and albedo draw a table of vcavity run")
        from vcavity.plots.sweep import check_sweep_request

        return check_sweep_request(table, output, theta_i_deg, orders, scale)
    if kind == "sweep":
        raise PlotError(f"--kind = 'sweep': {table.path.name} is a table of one run; --kind sweep draws a sweep "
                        "file (vcavity sweep); a table takes slice, map or albedo")
    if scale is not None and scale not in SCALES:
        raise PlotError(f"--scale = {scale!r}: accepted {', '.join(SCALES)}")
    if kind == "albedo" and scale == "log":
        raise PlotError("--scale = 'log': applies to --kind slice and map; albedo plots are linear")
    out = check_output(output if output is not None else default_output(table, kind))
    present = [int(k) for k in table.order]
    if orders:
        chosen = tuple(dict.fromkeys(parse_order(o) for o in orders))
        for k in chosen:
            if k not in present:
                need = " (run with track_all_orders = true)" if k == 0 else ""
                raise PlotError(f"--order = {'f_inf' if k == 0 else k}: table {table.path.name} has orders "
                                f"{_orders_text(table)}{need}")
    elif DEFAULT_ORDERS[kind] == "all":
        chosen = tuple(present)
    else:
        chosen = tuple(k for k in DEFAULT_ORDERS[kind] if k in present)
    chosen = tuple(sorted(chosen, key=lambda k: (k == 0, k)))  # f1, f2, ..., f_inf
    indices = select_theta(table.theta_i_deg, theta_i_deg, f"table {table.path.name}")
    chosen_models = ()
    if kind == "slice" and models and 1 in chosen:
        from vcavity.analytic.single_bounce import ModelNotApplicable
        from vcavity.compare import material_of_table

        try:
            material_of_table(table)
        except ModelNotApplicable as exc:
            raise PlotError(f"{str(exc).splitlines()[0]} (use --no-models to plot the table alone)") from None
        chosen_models = ("vcavity", "smith")
    return PlotRequest(kind=kind, output=out, indices=tuple(indices), orders=chosen,
                       scale=scale or DEFAULT_SCALE[kind], models=chosen_models)


def render(table, request: PlotRequest):
    """Draw and save a checked request; returns the plotted data (module docstring)."""
    if request.kind == "sweep":
        from vcavity.plots.sweep import render_sweep

        return render_sweep(table, request)
    from vcavity.plots import data as plot_data
    from vcavity.plots import figures

    if request.kind == "slice":
        models, notes = plot_data.build_models(table, request.models)
        for note in notes:
            plot_data.warn(note)
        result = [plot_data.slice_data(table, j, request.orders, models, notes) for j in request.indices]
        fig = figures.slice_figure(table, result, scale=request.scale)
    elif request.kind == "map":
        fig, result = figures.map_figure(table, request.indices, request.orders, scale=request.scale)
    else:
        result = plot_data.albedo_data(table, request.orders)
        if len(request.indices) < len(table.theta_i):
            keep = np.asarray(request.indices)
            result = plot_data.AlbedoData(
                groups=[(phi, members[np.isin(members, keep)]) for phi, members in result.groups
                        if np.isin(members, keep).any()],
                theta_i_deg=result.theta_i_deg, albedo=result.albedo, stderr=result.stderr,
                share=result.share, share_stderr=result.share_stderr)
        fig = figures.albedo_figure(table, result, request.orders)
    fig.savefig(request.output, dpi=110)
    return result


def plot_table(table, kind: str | None = None, output=None, **options):
    """Check, draw and save one plot of ``table``; returns the plotted data.

    ``options``: ``theta_i_deg``, ``orders``, ``scale``, ``models`` as in
    :func:`check_request`. ``table`` may be a path (of a table or of a sweep file), an
    open :class:`~vcavity.io.table.Table` or a :class:`~vcavity.io.sweep_table.SweepData`.

    Raises
    ------
    PlotError
        Bad request (one line), before anything is computed.
    """
    if isinstance(table, (str, os.PathLike)):
        from vcavity.io.sweep_table import is_sweep_file, open_sweep
        from vcavity.io.table import open_table

        table = open_sweep(table) if Path(table).is_file() and is_sweep_file(table) else open_table(table)
    return render(table, check_request(table, kind, output, **options))


__all__ = ["DEFAULT_ORDERS", "KINDS", "PlotError", "PlotRequest", "check_request", "parse_order",
           "plot_table", "render"]
