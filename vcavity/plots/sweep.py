"""``vcavity plot SWEEP.h5 --kind sweep``: albedo against roughness, from a sweep file.

One panel per incident direction (``theta_i_deg``, and ``phi_i_deg`` when swept), one
colour per combination of the other material axes (eta, kd, distribution, ...), one line
style per bounce order (f1 and f_inf by default), error bars of ±2 standard errors where
the sweep's estimator gives them (:mod:`vcavity.sweep.albedo`). The roughness axis is the
first of :data:`ROUGHNESS_AXES` the sweep varies (else the first it has). Points not done
are gaps. :func:`sweep_data` computes the numbers without matplotlib; :func:`render`
draws them and returns them.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from vcavity.io.schema import order_name, orders_text
from vcavity.plots.request import (
    PlotError,
    PlotRequest,
    check_output,
    default_field,
    parse_order,
    select_theta,
    sort_orders,
)
from vcavity.sweep.albedo import albedo, albedo_stderr, order_position, stderr_rule

#: Axes that are a roughness, in the order one is picked as the x axis.
ROUGHNESS_AXES = ("alpha", "alpha_x", "alpha_y", "sigma", "exponent")
INCIDENCE_AXES = ("theta_i_deg", "phi_i_deg")
NAME = "sweep"
SOURCE = "sweep"
SCALES = ("linear",)
DEFAULT_SCALE = "linear"
#: Orders drawn when none are asked for (those the sweep has).
DEFAULT_ORDERS = (1, 0)
MODELS = ()
#: Line style and marker of each order (colour says the material).
ORDER_STYLES = {0: ("-", "o"), 1: ("--", "s"), 2: (":", "^"), 3: ("-.", "D")}


def _value(v) -> str:
    return f"{v:g}" if isinstance(v, (int, float)) else str(v)


def roughness_axis(sweep):
    """The grid axis drawn along x (module docstring), or None when the sweep has none."""
    present = [a for name in ROUGHNESS_AXES for a in sweep.axes if a.name == name]
    varying = [a for a in present if len(a.values) > 1]
    return (varying or present or [None])[0]


@dataclass(frozen=True)
class SweepPlotData:
    """The numbers of a sweep plot.

    Attributes
    ----------
    roughness : str
        Name of the x axis (``alpha``, ``sigma``, ...).
    roughness_values : ndarray (n_r,)
        Its values, ascending.
    panels : list of dict
        Per panel, the incidence coordinates (``{"theta_i_deg": 45.0}``, plus
        ``phi_i_deg`` when it is a grid axis).
    lines : list of dict
        Per line, the values of the other point axes (``{"eta": 1.5, "kd": 0.9}``; ``{}``
        when there are none).
    orders : tuple of int
        Orders drawn (0 = f_inf).
    albedo, stderr : dict
        Order -> (n_panels, n_lines, n_r) albedo (NaN for points not done) and its standard
        error; ``stderr[order]`` is None where the estimator gives none.
    notes : list of str
    """

    roughness: str
    roughness_values: np.ndarray
    panels: list
    lines: list
    orders: tuple
    albedo: dict
    stderr: dict
    notes: list = field(default_factory=list)


def check(sweep, output=None, theta_i_deg=None, orders=None, scale=None, overwrite=False):
    """Check ``--kind sweep`` against a sweep file, computing nothing.

    ``scale`` was checked against :data:`SCALES` by :func:`vcavity.plots.check_request`.

    Returns
    -------
    vcavity.plots.PlotRequest
        ``indices`` are positions on the theta_i_deg axis (the panels).

    Raises
    ------
    vcavity.plots.PlotError
        One line: no roughness axis, a log scale, an order or theta_i the sweep lacks, a bad
        output.
    """
    name = sweep.path.name if sweep.path is not None else "(in memory)"
    if roughness_axis(sweep) is None:
        have = ", ".join(a.name for a in sweep.axes)
        raise PlotError(f"sweep {name} has no roughness axis (axes: {have}); --kind sweep draws albedo against "
                        f"one of {', '.join(ROUGHNESS_AXES)}: sweep one of them")
    if output is None and sweep.path is None:
        raise PlotError("-o is needed: the sweep has no file to put the plot beside")
    have = orders_text(sweep.order)
    if orders:
        chosen = tuple(dict.fromkeys(parse_order(o) for o in orders))
        for k in chosen:
            if order_position(sweep, k) is None:
                need = " (sweep with track_all_orders = true)" if k == 0 else ""
                raise PlotError(f"--order = {'f_inf' if k == 0 else k}: sweep {name} has orders {have}{need}")
    else:
        chosen = tuple(k for k in DEFAULT_ORDERS if order_position(sweep, k) is not None)
    chosen = sort_orders(chosen)
    theta = next(a for a in sweep.axes if a.name == "theta_i_deg").values
    indices = select_theta(theta, theta_i_deg, f"sweep {name}")
    # the output last: what to draw is reported first, whatever the output's state
    if output is None:
        out = check_output(sweep.path.with_name(f"{sweep.path.stem}_sweep.png"), overwrite, sweep.path,
                           default_field("sweep"))
    else:
        out = check_output(output, overwrite, sweep.path)
    return PlotRequest(kind="sweep", output=out, indices=tuple(indices), orders=chosen, scale="linear",
                       models=())


def sweep_data(sweep, theta_indices, orders) -> SweepPlotData:
    """The albedo of each order along the roughness axis, per panel and line (see
    :class:`SweepPlotData`); ``theta_indices`` are positions on the theta_i_deg axis."""
    axes = list(sweep.axes)
    names = [a.name for a in axes]
    rough = roughness_axis(sweep)
    rough_order = np.argsort(np.asarray(rough.values, dtype=np.float64), kind="stable")
    line_axes = [a for a in axes if a.name not in INCIDENCE_AXES and a.name != rough.name]
    phi_axis = next((a for a in axes if a.name == "phi_i_deg"), None)
    panel_positions = [(int(t), p) for t in theta_indices
                       for p in (range(len(phi_axis.values)) if phi_axis is not None else [None])]
    line_positions = list(itertools.product(*(range(len(a.values)) for a in line_axes)))
    varying = [a for a in line_axes if len(a.values) > 1]
    values, errors = {}, {}
    for k in orders:
        grid = albedo(sweep, k)
        error = albedo_stderr(sweep, k)
        shape = (len(panel_positions), len(line_positions), len(rough.values))
        values[k] = np.full(shape, np.nan)
        errors[k] = None if error is None else np.full(shape, np.nan)
        for i, (t, p) in enumerate(panel_positions):
            for j, line in enumerate(line_positions):
                where = {"theta_i_deg": t, "phi_i_deg": p, **{a.name: x for a, x in zip(line_axes, line)}}
                for r, position in enumerate(rough_order):
                    where[rough.name] = int(position)
                    index = tuple(where[n] for n in names)
                    values[k][i, j, r] = grid[index]
                    if error is not None:
                        errors[k][i, j, r] = error[index]
    theta_axis = axes[names.index("theta_i_deg")]
    panels = []
    for t, p in panel_positions:
        panel = {"theta_i_deg": theta_axis.values[t]}
        if phi_axis is not None:
            panel["phi_i_deg"] = phi_axis.values[p]
        panels.append(panel)
    lines = [{a.name: a.values[x] for a, x in zip(line_axes, line) if a in varying} for line in line_positions]
    notes = []
    pending = int(np.sum(np.asarray(sweep.data["done"]) != 1))
    if pending:
        notes.append(f"{pending} of {np.asarray(sweep.data['done']).size} points not done (gaps)")
    if any(errors[k] is None for k in orders):
        missing = ", ".join(order_name(k) for k in orders if errors[k] is None)
        notes.append(f"no error bars for {missing}: "
                     f"{stderr_rule(str(sweep.attrs.get('estimator', 'analog')))}")
    return SweepPlotData(roughness=rough.name,
                         roughness_values=np.asarray(rough.values, dtype=np.float64)[rough_order],
                         panels=panels, lines=lines, orders=tuple(orders), albedo=values, stderr=errors,
                         notes=notes)


def _shared_text(sweep, rough_name) -> str:
    """What every line shares: /material, the single-valued axes, the scalar incidence."""
    from vcavity.io.summary import format_material

    shared = dict(sweep.material)
    shared.update({a.name: a.values[0] for a in sweep.axes if len(a.values) == 1
                   and a.name not in INCIDENCE_AXES and a.name != rough_name})
    text = format_material(shared)
    if "microsurface" not in shared and any(a.name == "microsurface" for a in sweep.axes):
        text = text.split(", ", 1)[1]  # swept: "v-cavity microsurface, ..." (the default) would be wrong
    text += "".join(f", {k} = {_value(v)}°" for k, v in sweep.scalars.items() if k == "phi_i_deg" and v != 0.0)
    return text


def sweep_figure(sweep, data: SweepPlotData):
    """The figure of :func:`sweep_data`'s numbers (module docstring)."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from vcavity.plots.figures import panel_grid

    rows, columns = panel_grid(len(data.panels))
    fig = Figure(figsize=(max(4.8 * columns, 7.5), 3.9 * rows + 1.6), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False, sharey=True).ravel()
    n_lines = len(data.lines)
    if n_lines <= 10:
        colours = [f"C{j}" for j in range(n_lines)]
    else:
        from matplotlib import colormaps

        colours = [colormaps["viridis"](x) for x in np.linspace(0.0, 0.9, n_lines)]
    rough = next(a for a in sweep.axes if a.name == data.roughness)
    x = data.roughness_values
    top = 0.0
    for ax, (i, panel) in zip(axes, enumerate(data.panels)):
        for k in data.orders:
            style, marker = ORDER_STYLES.get(int(k), ("-", "v"))
            for j in range(n_lines):
                y = data.albedo[k][i, j]
                err = None if data.stderr[k] is None else 2.0 * data.stderr[k][i, j]
                ax.errorbar(x, y, yerr=err, color=colours[j], linestyle=style, marker=marker, markersize=4,
                            capsize=2, linewidth=1.4 if k == 0 else 1.1)
                high = y + (err if err is not None else 0.0)
                if np.any(np.isfinite(high)):
                    top = max(top, float(np.nanmax(high)))
        title = f"theta_i = {_value(panel['theta_i_deg'])}°"
        if "phi_i_deg" in panel:
            title += f", phi_i = {_value(panel['phi_i_deg'])}°"
        ax.set_title(title, fontsize=10)
        units = "" if rough.units in (None, "1") else f" ({rough.units})"
        ax.set_xlabel(f"{rough.name}{units}: {rough.long_name}" if rough.long_name not in ("", rough.name)
                      else f"{rough.name}{units}", fontsize=8)
        if x.size > 1 and x[0] > 0 and x[-1] / x[0] > 50.0:  # decades of roughness: spread them out
            ax.set_xscale("log")
        ax.grid(True, alpha=0.3)
    for ax in axes[::columns]:
        ax.set_ylabel("directional albedo (fraction of incident light)", fontsize=8)
    axes[0].set_ylim(0.0, max(1.05 * top, 0.05))
    for ax in axes[len(data.panels):]:
        ax.set_visible(False)
    handles, labels = [], []
    for j, line in enumerate(data.lines):
        handles.append(Line2D([], [], color=colours[j], linewidth=6, alpha=0.8))
        labels.append(", ".join(f"{k} = {_value(v)}" for k, v in line.items()) or "albedo")
    for k in data.orders:
        style, marker = ORDER_STYLES.get(int(k), ("-", "v"))
        handles.append(Line2D([], [], color="0.2", linestyle=style, marker=marker, markersize=4))
        labels.append(order_name(k) if k != 0 else "f_inf (all orders)")
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 6 if columns > 1 else 4),
               fontsize=8, frameon=False)
    bars = "error bars ±2 std. errors" if any(data.stderr[k] is not None for k in data.orders) else "no error bars"
    name = sweep.path.name if sweep.path is not None else "sweep"
    fig.suptitle(f"{name}: albedo against {data.roughness}; {_shared_text(sweep, data.roughness)}\n"
                 f"colour = material, line style = bounce order; {bars}"
                 + ("\n" + "; ".join(data.notes) if data.notes else ""), fontsize=9)
    return fig


def render(sweep, request):
    """Draw a checked ``--kind sweep`` request; returns ``(figure, SweepPlotData)``."""
    data = sweep_data(sweep, request.indices, request.orders)
    return sweep_figure(sweep, data), data


__all__ = ["DEFAULT_ORDERS", "ROUGHNESS_AXES", "SweepPlotData", "check", "render",
           "roughness_axis", "sweep_data", "sweep_figure"]
