"""Plots of vcavity tables and sweep files (``vcavity plot``), one module per kind.

``plot_table(table, kind, output, ...)`` checks the request (:func:`check_request`,
one-line :class:`PlotError` before anything is computed), draws and saves the figure,
and returns the numbers it plotted, so tests and scripts can check them without
reading pixels. The kinds (:data:`KIND_MODULES`, one module each, each with the same
``NAME``, ``SOURCE``, ``SCALES``, ``DEFAULT_SCALE``, ``DEFAULT_ORDERS``, ``MODELS`` and
``render(source, request) -> (figure, data)``; a sweep kind also ``check``):

- ``"slice"`` (:mod:`vcavity.plots.slice`): in-plane slices of f1, f2 and f_inf with the
  single-bounce models of f1. Returns a list of :class:`~vcavity.plots.data.SliceData`.
- ``"map"`` (:mod:`vcavity.plots.map`): equal-area hemispherical maps of each order.
  Returns ``{(incidence index, order): (N, N) values}``.
- ``"albedo"`` (:mod:`vcavity.plots.albedo`): albedo per order against theta_i and the
  inter-reflection share. Returns :class:`~vcavity.plots.data.AlbedoData`.
- ``"sweep"`` (:mod:`vcavity.plots.sweep`): of a sweep file (the default kind for one):
  albedo of f1 and f_inf against the roughness axis. Returns
  :class:`~vcavity.plots.sweep.SweepPlotData`. The other kinds draw a table of one run.
- ``"versus"`` (:mod:`vcavity.plots.versus`): two tables of one material (or two points of
  a sweep file, ``points`` and ``versus``), side by side and their difference ``B - A``
  with ±2 sigma. Returns :class:`~vcavity.plots.versus.VersusData`.

Only ``"slice"`` with models imports the analytic package (and Numba).
"""

from __future__ import annotations

import os
from pathlib import Path

# aliased: `map` and `slice` would shadow the builtins in this namespace
from vcavity.io.schema import orders_text
from vcavity.plots import albedo as albedo_kind
from vcavity.plots import map as map_kind
from vcavity.plots import slice as slice_kind
from vcavity.plots import sweep as sweep_kind
from vcavity.plots import versus as versus_kind
from vcavity.plots.request import (
    OUTPUT_SUFFIXES,
    PlotError,
    PlotRequest,
    check_output,
    default_field,
    default_output,
    parse_order,
    save,
    select_theta,
    sort_orders,
)

#: The plot kinds by name: adding one is a module like :mod:`vcavity.plots.map` plus a line here.
KIND_MODULES = {kind.NAME: kind for kind in (slice_kind, map_kind, albedo_kind, sweep_kind,
                                                    versus_kind)}
KINDS = tuple(KIND_MODULES)
SCALES = tuple(dict.fromkeys(s for kind in KIND_MODULES.values() for s in kind.SCALES))
DEFAULT_SCALE = {name: kind.DEFAULT_SCALE for name, kind in KIND_MODULES.items()}
#: Orders drawn when none are asked for; "all" = every order of the table.
DEFAULT_ORDERS = {name: kind.DEFAULT_ORDERS for name, kind in KIND_MODULES.items()}


def _kinds_of(source: str) -> list:
    return [name for name, kind in KIND_MODULES.items() if kind.SOURCE == source]


def _spoken(names, conjunction: str) -> str:
    """``"a, b and c"``: a list as a sentence says it."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} {conjunction} {names[-1]}"


def _is_sweep(source) -> bool:
    from vcavity.io.sweep_table import SweepData  # h5py loads only when a file is read

    return isinstance(source, SweepData)


def check_scale(kind: str, scale: str | None) -> None:
    """Refuse a ``--scale`` the kind does not draw (one-line :class:`PlotError`)."""
    if scale is None:
        return
    if scale not in SCALES:
        raise PlotError(f"--scale = {scale!r}: accepted {', '.join(SCALES)}")
    accepted = KIND_MODULES[kind].SCALES
    if scale not in accepted:
        users = [name for name, module in KIND_MODULES.items() if scale in module.SCALES]
        raise PlotError(f"--scale = {scale!r}: applies to --kind {_spoken(users, 'and')}; {kind} plots are "
                        f"{_spoken(list(accepted), 'or')}")


def _check_table_request(table, module, output, theta_i_deg, orders, scale, models, overwrite) -> PlotRequest:
    """The request of a kind that draws a table of one run (``SOURCE = "table"``)."""
    kind = module.NAME
    present = [int(k) for k in table.order]
    if orders:
        chosen = tuple(dict.fromkeys(parse_order(o) for o in orders))
        for k in chosen:
            if k not in present:
                need = " (run with track_all_orders = true)" if k == 0 else ""
                raise PlotError(f"--order = {'f_inf' if k == 0 else k}: table {table.path.name} has orders "
                                f"{orders_text(table.order)}{need}")
    elif module.DEFAULT_ORDERS == "all":
        chosen = tuple(present)
    else:
        chosen = tuple(k for k in module.DEFAULT_ORDERS if k in present)
    chosen = sort_orders(chosen)
    indices = select_theta(table.theta_i_deg, theta_i_deg, f"table {table.path.name}")
    chosen_models = ()
    if module.MODELS and models and 1 in chosen:
        from vcavity.analytic.single_bounce import ModelNotApplicable
        from vcavity.compare import material_of_table  # the models import Numba: only when drawn

        try:
            material_of_table(table)
        except ModelNotApplicable as exc:
            raise PlotError(f"{str(exc).splitlines()[0]} (use --no-models to plot the table alone)") from None
        chosen_models = tuple(module.MODELS)
    # the output last: what to draw is reported first, whatever the output's state
    if output is None:
        out = check_output(default_output(table, kind), overwrite, table.path, default_field(kind))
    else:
        out = check_output(output, overwrite, table.path)
    return PlotRequest(kind=kind, output=out, indices=tuple(indices), orders=chosen,
                       scale=scale or module.DEFAULT_SCALE, models=chosen_models)


def _check_versus(first, second, output, theta_i_deg, orders, scale, overwrite, points, versus, force):
    """The request of ``--kind versus``: two tables, or two points of one sweep file."""
    from vcavity.plots.sides import sweep_sides, table_side

    name = first.path.name if first.path is not None else "the input"
    if second is None:
        if not _is_sweep(first):
            raise PlotError(f"--kind 'versus': draws two tables (vcavity plot A.h5 B.h5 --kind versus) or two points "
                            f"of a sweep file (--point, --versus); {name} is one table")
        sides = sweep_sides(first, points, versus)
        sources = (first.path,)
    else:
        for source in (first, second):
            if _is_sweep(source):
                raise PlotError(f"--kind 'versus': {source.path.name} is a sweep file; two inputs must be tables "
                                "(two points of one sweep: vcavity plot SWEEP.h5 --kind versus --point ...)")
        if points or versus:
            raise PlotError(f"--{'point' if points else 'versus'}: chooses points of a sweep file; "
                            f"{first.path.name} and {second.path.name} are tables")
        sides = (table_side(first), table_side(second))
        sources = (first.path, second.path)
    default = first.path.with_name(f"{first.path.stem}_versus.png") if first.path is not None else None
    if output is None and default is None:
        raise PlotError("-o is needed: the sweep has no file to put the plot beside")
    return versus_kind.check(*sides, output=output, theta_i_deg=theta_i_deg, orders=orders, scale=scale,
                             overwrite=overwrite, force=force, default_output=default, sources=sources)


def check_request(table, kind: str | None = None, output=None, theta_i_deg=None, orders=None,
                  scale: str | None = None, models: bool = True, overwrite: bool = False, second=None,
                  points=(), versus: str | None = None, force: bool = False) -> PlotRequest:
    """Check a plot request against a table (or a sweep) without computing anything.

    Parameters
    ----------
    table : vcavity.io.table.Table or vcavity.io.sweep_table.SweepData
        A sweep takes the kinds whose ``SOURCE`` is ``"sweep"`` (``kind = "sweep"``), a
        table every other kind.
    kind : str, optional
        One of :data:`KINDS`; default ``"sweep"`` for a sweep, ``"slice"`` for a table.
    output : path, optional
        Default :func:`~vcavity.plots.request.default_output`.
    theta_i_deg : sequence of float or str, optional
        Incident polar angles (deg, as in the run config) to draw; default all. Every
        direction with that theta_i is drawn (whatever its phi_i).
    orders : sequence of int or str, optional
        Orders (:func:`parse_order`); default :data:`DEFAULT_ORDERS` present in the table.
    scale : {"log", "linear"}, optional
        Value axis of slices and colour scale of maps; default :data:`DEFAULT_SCALE`.
    models : bool
        Slices: overlay the single-bounce models of f1.
    overwrite : bool
        Replace an existing output file (``--overwrite``); links, FIFOs, folders and the
        input itself never are (:func:`~vcavity.plots.request.check_output`).
    second : vcavity.io.table.Table, optional
        A second table: ``kind`` must be ``"versus"`` (its default then).
    points : sequence of str
        ``--kind versus`` of a sweep: ``AXIS=VALUE`` fixing point axes (:func:`vcavity.plots.sides.sweep_sides`).
    versus : str, optional
        ``--kind versus`` of a sweep: the compared axis, ``AXIS`` or ``AXIS=A,B``.
    force : bool
        ``--kind versus``: compare materials that differ in more than the microsurface.

    Returns
    -------
    PlotRequest or vcavity.plots.versus.VersusRequest

    Raises
    ------
    PlotError
        One line naming the option, the value and what is accepted.
    """
    source = "sweep" if _is_sweep(table) else "table"
    if kind is None:
        kind = "versus" if second is not None else _kinds_of(source)[0]
    if kind not in KIND_MODULES:
        raise PlotError(f"--kind = {kind!r}: accepted {', '.join(KINDS)}")
    module = KIND_MODULES[kind]
    if kind != versus_kind.NAME:
        if second is not None:
            raise PlotError(f"--kind = {kind!r}: draws one input; two ({table.path.name}, {second.path.name}) "
                            "are drawn with --kind versus")
        for option, given in (("--point", points), ("--versus", versus), ("--force", force)):
            if given:
                raise PlotError(f"{option}: applies to --kind versus, not {kind}")
    else:
        check_scale(kind, scale)
        return _check_versus(table, second, output, theta_i_deg, orders, scale, overwrite, points, versus, force)
    table_kinds = _kinds_of("table")
    if source == "sweep" and module.SOURCE != "sweep":
        raise PlotError(f"--kind = {kind!r}: {table.path.name if table.path else 'this'} is a sweep file "
                        "(vcavity sweep), drawn with --kind sweep (albedo against roughness); "
                        f"{_spoken(table_kinds, 'and')} draw a table of vcavity run")
    if source == "table" and module.SOURCE != "table":
        raise PlotError(f"--kind = {kind!r}: {table.path.name} is a table of one run; --kind {kind} draws a sweep "
                        f"file (vcavity sweep); a table takes {_spoken(table_kinds, 'or')}")
    check_scale(kind, scale)
    if module.SOURCE == "sweep":
        return module.check(table, output, theta_i_deg, orders, scale, overwrite)
    return _check_table_request(table, module, output, theta_i_deg, orders, scale, models, overwrite)


def render(table, request: PlotRequest, cancelled=None):
    """Draw and save (atomically) a checked request; returns the plotted data (module docstring).

    ``cancelled()``, if given, is asked just before the rename (as in
    :func:`vcavity.io.atomic.replace_atomically`): True cancels the write."""
    fig, result = KIND_MODULES[request.kind].render(table, request)
    save(fig, request.output, cancelled=cancelled)
    return result


def plot_table(table, kind: str | None = None, output=None, **options):
    """Check, draw and save one plot of ``table``; returns the plotted data.

    ``options``: ``theta_i_deg``, ``orders``, ``scale``, ``models``, ``overwrite``, ``second``,
    ``points``, ``versus``, ``force`` as in :func:`check_request`. ``table`` (and ``second``)
    may be a path (of a table or of a sweep file), an open :class:`~vcavity.io.table.Table`
    or a :class:`~vcavity.io.sweep_table.SweepData`.

    Raises
    ------
    PlotError
        Bad request (one line), before anything is computed.
    """
    table = _opened(table)
    if options.get("second") is not None:
        options["second"] = _opened(options["second"])
    return render(table, check_request(table, kind, output, **options))


def _opened(table):
    """A table or sweep file read from a path; anything else as given."""
    if isinstance(table, (str, os.PathLike)):
        from vcavity.io.sweep_table import is_sweep_file, open_sweep
        from vcavity.io.table import open_table

        return open_sweep(table) if Path(table).is_file() and is_sweep_file(table) else open_table(table)
    return table


__all__ = ["DEFAULT_ORDERS", "DEFAULT_SCALE", "KINDS", "KIND_MODULES", "OUTPUT_SUFFIXES", "PlotError",
           "PlotRequest", "SCALES", "check_output", "check_request", "check_scale", "parse_order", "plot_table",
           "render", "save", "select_theta"]
