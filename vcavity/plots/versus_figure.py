"""The matplotlib figure of ``--kind versus`` (numbers: :func:`vcavity.plots.versus.versus_data`).

Panels in pairs, a value panel over a difference panel: first the albedo per order
against theta_i, then one pair per incident direction with the in-plane slices. A is
drawn solid, B dashed, one colour per order (as ``--kind slice``); differences are
``B - A`` with bands (slices) or error bars (albedo) of ±2 sigma, sigma the quadrature
sum of both standard errors.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from vcavity.io.schema import order_name
from vcavity.io.summary import format_material
from vcavity.plots.figures import _colour, _log_floor
from vcavity.plots.sides import differences_text

MAX_COLUMNS = 4
STYLES = ({"linestyle": "-", "marker": "o"}, {"linestyle": "--", "marker": "s"})


def _shade(ax, edges, value, err, colour, scale="linear"):
    low, high = value - 2.0 * err, value + 2.0 * err
    if scale == "log":
        low = np.maximum(low, 1e-300)
    ax.stairs(high, edges, baseline=low, fill=True, color=colour, alpha=0.2, linewidth=0)


def _albedo_pair(top, bottom, data):
    # one line per phi_i (an anisotropic table's azimuths), each sorted by theta_i
    phi = np.round(data.phi_i_deg, 9)
    for value in np.unique(phi):
        members = np.flatnonzero(phi == value)
        order = members[np.argsort(data.theta_i_deg[members], kind="stable")]
        theta = data.theta_i_deg[order]
        for k in data.orders:
            for s in (0, 1):
                err = data.albedo_stderr[s][k]
                top.errorbar(theta, data.albedo[s][k][order], yerr=None if err is None else 2.0 * err[order],
                             color=_colour(k), markersize=4, capsize=2, linewidth=1.2, **STYLES[s])
            err = data.albedo_difference_stderr[k]
            bottom.errorbar(theta, data.albedo_difference[k][order],
                            yerr=None if err is None else 2.0 * err[order], color=_colour(k), marker="o",
                            markersize=4, capsize=2, linewidth=1.2)
    several = np.unique(phi).size > 1
    top.set_title("albedo per order" + (" (one line per phi_i)" if several else ""), fontsize=10)
    top.set_ylabel("directional albedo")
    top.set_ylim(bottom=0.0)
    bottom.axhline(0.0, color="0.4", linewidth=0.8)
    bottom.set_ylabel("albedo B - A")
    bottom.set_xlabel("theta_i (deg)")
    for ax in (top, bottom):
        ax.set_xlim(-2.0, 92.0)
        ax.grid(True, alpha=0.3)


def _slice_pair(top, bottom, pair, difference, stderr, orders, scale):
    drawn = []
    for s, piece in enumerate(pair):
        for k in orders:
            value = piece.brdf[k]
            _shade(top, piece.edges, value, piece.stderr[k], _colour(k), scale)
            shown = np.where(value > 0, value, np.nan) if scale == "log" else value
            top.stairs(shown, piece.edges, color=_colour(k), linewidth=1.3, baseline=None,
                       linestyle=STYLES[s]["linestyle"])
            drawn.append(value)
    edges = pair[0].edges
    for k in orders:
        _shade(bottom, edges, difference[k], stderr[k], _colour(k))
        bottom.stairs(difference[k], edges, color=_colour(k), linewidth=1.2, baseline=None)
    first = pair[0]
    top.set_title(f"theta_i = {first.theta_i_deg:g}°, phi_i = {first.phi_i_deg:g}°", fontsize=10)
    if scale == "log":
        top.set_yscale("log")
        top.set_ylim(*_log_floor(drawn))
    else:
        top.set_ylim(bottom=0.0)
    top.set_ylabel("BRDF, cell average (1/sr)")
    bottom.axhline(0.0, color="0.4", linewidth=0.8)
    bottom.set_ylabel("B - A (1/sr)")
    bottom.set_xlabel("theta_o in the plane of incidence (deg); < 0 toward the light", fontsize=8)
    for ax in (top, bottom):
        ax.axvline(first.theta_i_deg, color="0.55", linewidth=0.8, linestyle="-.")
        ax.set_xlim(-90.0, 90.0)
        ax.set_xticks(np.arange(-90, 91, 30))
        ax.grid(True, alpha=0.3)


def versus_figure(a, b, data, scale: str = "log") -> Figure:
    """The albedo pair and one slice pair per direction of ``data`` (module docstring)."""
    n_panels = 1 + len(data.slices)
    rows = math.ceil(n_panels / MAX_COLUMNS)
    columns = math.ceil(n_panels / rows)  # 5 panels: 3 + 2, not 4 + 1
    fig = Figure(figsize=(4.4 * columns + 0.4, 5.6 * rows + 1.3), layout="constrained")
    axes = fig.subplots(2 * rows, columns, squeeze=False, height_ratios=[2.0, 1.2] * rows)
    pairs = [(axes[2 * (p // columns), p % columns], axes[2 * (p // columns) + 1, p % columns])
             for p in range(rows * columns)]
    _albedo_pair(*pairs[0], data)
    for (top, bottom), pair, difference, stderr in zip(pairs[1:], data.slices, data.difference,
                                                       data.difference_stderr):
        _slice_pair(top, bottom, pair, difference, stderr, data.orders, scale)
    for top, bottom in pairs[n_panels:]:
        top.set_visible(False)
        bottom.set_visible(False)
    handles = [Line2D([], [], color=_colour(k), linewidth=2) for k in data.orders]
    labels = [order_name(k) if k else "f_inf (all orders)" for k in data.orders]
    for s, label in enumerate(data.labels):
        handles.append(Line2D([], [], color="0.2", markersize=4, **STYLES[s]))
        labels.append(f"{'AB'[s]}: {label}")
    handles.append(Line2D([], [], color="0.2", marker="o", markersize=4))
    models = " and ".join(name for name, side in zip("AB", (a, b)) if side.deterministic)
    errors = f"errors ({models}: the exact model's own error estimate)" if models else "std. errors"
    labels.append(f"B - A (±2 sigma, sigma = quadrature sum of both {errors})")
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False)
    shared = {k: v for k, v in a.material.items() if k not in data.differs and k not in a.compared}
    text = format_material(shared)
    if a.material.get("microsurface", "v-cavity") != b.material.get("microsurface", "v-cavity"):
        text = text.split(", ", 1)[1]  # "<surface> microsurface, ..." would name A's alone
    title = f"A: {data.labels[0]}   B: {data.labels[1]}\n{text}"
    if data.differs:
        title += f"\nforced (--force): the materials differ in {differences_text(data.differs)}"
    fig.suptitle(title + f"\nbands and error bars ±2 {errors if models else 'standard errors'}; steps = sensor cells "
                 "crossed by the plane",
                 fontsize=9)
    return fig


__all__ = ["versus_figure"]
