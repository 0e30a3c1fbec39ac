"""Matplotlib figures of tables: in-plane slices, hemispherical maps, albedos.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot, so no
global backend state and no display needed); ``Figure.savefig`` renders with Agg.
The numbers come from :mod:`vcavity.plots.data`.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure

from vcavity.io.schema import order_name
from vcavity.plots.data import SLICE_MODELS
from vcavity.io.summary import format_material
from vcavity.sensor.grid import square_to_hemisphere_array

#: Colour of each order (f_inf black, then matplotlib's cycle), and of the models.
ORDER_COLOURS = {0: "black", 1: "tab:blue", 2: "tab:orange", 3: "tab:green", 4: "tab:olive"}
MODEL_STYLES = {"vcavity": dict(color="tab:red", linestyle="--"),
                "smith": dict(color="tab:purple", linestyle=":")}
#: Log scales show at most this many decades below the largest value.
LOG_DECADES = 4.0


def _colour(k):
    return ORDER_COLOURS.get(int(k), "tab:gray")


def _log_floor(arrays, decades=LOG_DECADES):
    """Bottom of a log axis: the smallest positive value, but at most ``decades`` below the top."""
    positive = np.concatenate([a[np.isfinite(a) & (a > 0)] for a in arrays] + [np.array([])])
    if positive.size == 0:
        return 1e-3, 1.0
    top = float(positive.max())
    return max(float(positive.min()) * 0.7, top * 10.0 ** -decades), top * 1.5


def draw_slice(ax, data, scale: str = "log", legend: bool = False, title: str | None = None):
    """Draw one :class:`~vcavity.plots.data.SliceData` on ``ax``.

    Table orders as steps (one step per stretch of the plane inside a cell) with a band
    of ±2 standard errors; models as dashed / dotted steps over the same cells. With
    ``legend`` the legend goes inside ``ax``; otherwise collect it with
    ``ax.get_legend_handles_labels()`` (as :func:`slice_figure` does).
    """
    drawn = []
    # f_inf first and widest, so a lower order equal to it (a near-specular f1) stays visible on top
    for k in sorted(data.brdf, key=lambda k: (k != 0, k)):
        value, err = data.brdf[k], data.stderr[k]
        colour, width = _colour(k), 2.4 if k == 0 else 1.3
        shown = np.where(value > 0, value, np.nan) if scale == "log" else value
        low, high = value - 2.0 * err, value + 2.0 * err
        if scale == "log":
            low = np.maximum(low, 1e-300)
        ax.stairs(high, data.edges, baseline=low, fill=True, color=colour, alpha=0.22, linewidth=0)
        ax.stairs(shown, data.edges, color=colour, linewidth=width, baseline=None)
        band = "±2 model error band" if data.model_error else "±2 s.e. band"
        ax.plot([], [], color=colour, linewidth=width, label=f"table {order_name(k)} ({band})")
        drawn.append(value)
    for name, curve in data.models.items():
        ax.stairs(curve, data.edges, baseline=None, linewidth=1.3, **MODEL_STYLES[name])
        ax.plot([], [], linewidth=1.3, label=f"{SLICE_MODELS[name]} of f1", **MODEL_STYLES[name])
        drawn.append(curve)
    ax.axvline(data.theta_i_deg, color="0.55", linewidth=0.8, linestyle="-.", label="mirror direction")
    ax.set_xlim(-90.0, 90.0)
    ax.set_xticks(np.arange(-90, 91, 30))
    if scale == "log":
        ax.set_yscale("log")
        ax.set_ylim(*_log_floor(drawn))
    else:
        tops = [v + 2.0 * data.stderr[k] for k, v in data.brdf.items()] + list(data.models.values())
        ax.set_ylim(0.0, 1.05 * max((float(np.nanmax(a)) for a in tops if a.size), default=1.0))
    ax.set_xlabel("theta_o in the plane of incidence (deg)")
    ax.set_ylabel("BRDF, cell average (1/sr)")
    ax.text(0.02, 0.02, "toward light\nphi_o = phi_i", transform=ax.transAxes, fontsize=7, color="0.35",
            va="bottom")
    ax.text(0.98, 0.02, "specular side\nphi_o = phi_i + 180", transform=ax.transAxes, fontsize=7,
            color="0.35", va="bottom", ha="right")
    ax.set_title(title or f"theta_i = {data.theta_i_deg:g} deg, phi_i = {data.phi_i_deg:g} deg", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    if legend:
        ax.legend(fontsize=7, loc="upper left", framealpha=0.85)


def figure_legend(fig, ax):
    """One legend for the whole figure, below the panels (every panel draws the same curves)."""
    handles, labels = ax.get_legend_handles_labels()
    columns = 3 if fig.get_figwidth() < 9 else 4 if fig.get_figwidth() < 12 else 7
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), columns), fontsize=8,
               frameon=False)


def panel_grid(n_panels, max_columns=4):
    """Rows and columns of a figure of ``n_panels`` panels, at most ``max_columns`` wide."""
    columns = min(n_panels, max_columns)
    return math.ceil(n_panels / columns), columns


def slice_figure(table, datas, scale: str = "log") -> Figure:
    """One slice panel per incident direction (up to 4 per row)."""
    rows, columns = panel_grid(len(datas))
    fig = Figure(figsize=(max(4.6 * columns, 7.5), 3.9 * rows + 0.9), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax, data in zip(axes, datas):
        draw_slice(ax, data, scale=scale)
    for ax in axes[len(datas):]:
        ax.set_visible(False)
    figure_legend(fig, axes[0])
    notes = sorted({note for d in datas for note in d.notes})
    bands = ("±2 model errors (the exact model's own error estimate)" if any(d.model_error for d in datas)
             else "±2 std. errors")
    fig.suptitle(f"{table.path.name}: {format_material(table.material)}\n"
                 f"in-plane slices, steps = sensor cells crossed by the plane, bands = {bands}"
                 + ("\n" + "; ".join(notes) if notes else ""), fontsize=10)
    return fig


def _disk(points):
    """Equal-area disk coordinates of hemisphere directions: ``(x, y)/sqrt(1 + z)``, the
    Lambert azimuthal projection the sensor's map lifts from (physics.md sec. 6), radius
    ``sqrt(1 - cos theta)``."""
    scale = 1.0 / np.sqrt(1.0 + points[..., 2])
    return points[..., 0] * scale, points[..., 1] * scale


def _disk_mesh(resolution):
    edges = np.linspace(-1.0, 1.0, resolution + 1)
    corners = square_to_hemisphere_array(edges[None, :], edges[:, None])  # [iy, ix]
    return _disk(corners)


def _decorate_disk(ax, theta_i, phi_i):
    ring = np.linspace(0.0, 2.0 * np.pi, 361)
    for theta in (30.0, 60.0, 90.0):
        r = math.sqrt(1.0 - math.cos(math.radians(theta)))
        ax.plot(r * np.cos(ring), r * np.sin(ring), color="white" if theta < 90 else "0.3",
                linewidth=0.6, alpha=0.7)
        if theta < 90:
            ax.text(r * math.cos(math.radians(100)), r * math.sin(math.radians(100)), f"{theta:g}°",
                    color="white", fontsize=6, ha="center")
    r_i = math.sqrt(1.0 - math.cos(theta_i))
    ax.plot([r_i * math.cos(phi_i)], [r_i * math.sin(phi_i)], marker="o", mfc="none", mec="white",
            markersize=7, linestyle="none", label="light")
    ax.plot([-r_i * math.cos(phi_i)], [-r_i * math.sin(phi_i)], marker="x", color="white",
            markersize=7, linestyle="none", label="mirror")
    ax.set_aspect("equal")
    ax.set_frame_on(False)
    ax.set_xlim(-1.03, 1.03)
    ax.set_ylim(-1.03, 1.03)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_xlabel("+x (phi_o = 0) →", fontsize=7)
    ax.set_ylabel("+y (phi_o = 90°) →", fontsize=7)


def map_figure(table, indices, orders, scale: str = "linear"):
    """Hemispherical maps: one row per incident direction, one column per order.

    Each cell is drawn as the image of its square under the sensor's map projected on
    the equal-area disk (``_disk``), so areas on the page are solid angles. Each panel
    has its own colour bar (orders differ by decades); a log scale leaves empty cells
    blank.

    Returns
    -------
    Figure, dict
        The figure and ``{(index, order): (N, N) array [iy, ix]}`` of the plotted values.
    """
    n = table.sensor.resolution
    mesh_x, mesh_y = _disk_mesh(n)
    rows, columns = len(indices), len(orders)
    fig = Figure(figsize=(3.3 * columns + 0.6, 3.0 * rows + 0.7), layout="constrained")
    axes = fig.subplots(rows, columns, squeeze=False)
    plotted = {}
    for r, j in enumerate(indices):
        for c, k in enumerate(orders):
            values = np.asarray(table.brdf[j, table.order_index(int(k))]).reshape(n, n)
            plotted[(int(j), int(k))] = values
            ax = axes[r, c]
            if scale == "log":
                floor, top = _log_floor([values])
                norm = LogNorm(vmin=floor, vmax=max(top / 1.5, floor * 10))
                shown = np.ma.masked_less_equal(values, 0.0)
            else:
                norm, shown = Normalize(vmin=0.0, vmax=max(float(values.max()), 1e-12)), values
            image = ax.pcolormesh(mesh_x, mesh_y, shown, norm=norm, cmap="magma", shading="flat",
                                  rasterized=True)
            _decorate_disk(ax, float(table.theta_i[j]), float(table.phi_i[j]))
            ax.set_title(f"{order_name(k)}, theta_i = {table.theta_i_deg[j]:g}°, "
                         f"phi_i = {table.phi_i_deg[j]:g}°", fontsize=8)
            fig.colorbar(image, ax=ax, shrink=0.85, label="BRDF (1/sr)")
    axes[0, 0].legend(fontsize=6, loc="lower left", facecolor="0.4", labelcolor="white", framealpha=0.8)
    fig.suptitle(f"{table.path.name}: {format_material(table.material)}\nequal-area maps of the "
                 "upper hemisphere (rings at theta_o = 30, 60, 90 deg), cell averages", fontsize=9)
    return fig, plotted


def albedo_figure(table, data, orders) -> Figure:
    """Albedo per order against theta_i, and the inter-reflection share ``(f_inf - f1)/f_inf``."""
    fig = Figure(figsize=(10.5, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    markers = ("o", "s", "^", "D", "v")
    several = len(data.groups) > 1
    for g, (phi, members) in enumerate(data.groups):
        theta = data.theta_i_deg[members]
        suffix = f", phi_i = {phi:g}°" if several else ""
        for k in sorted(orders, key=lambda k: (k == 0, k)):
            left.errorbar(theta, data.albedo[k][members], yerr=2.0 * data.stderr[k][members],
                          color=_colour(k), marker=markers[g % len(markers)], markersize=4, capsize=2,
                          label=f"{order_name(k)}{suffix}")
        if data.share is not None:
            share_error = None if data.share_stderr is None else 2.0 * data.share_stderr[members]
            right.errorbar(theta, data.share[members], yerr=share_error, color="tab:red",
                           marker=markers[g % len(markers)], markersize=4, capsize=2,
                           label=f"(f_inf - f1) / f_inf{suffix}")
    left.set_xlabel("theta_i (deg)")
    left.set_ylabel("directional albedo (fraction of incident light)")
    bars = "±2 model errors, the cells' error estimates summed" if data.model_error else "±2 std. errors"
    left.set_title(f"albedo per bounce order (error bars {bars})", fontsize=9)
    left.set_xlim(-2.0, 92.0)
    left.set_ylim(bottom=0.0)
    left.legend(fontsize=7)
    left.grid(True, alpha=0.3)
    right.set_xlabel("theta_i (deg)")
    right.set_ylabel("share of exiting light that bounced twice or more")
    right.set_title("inter-reflection share (f_inf - f1) / f_inf", fontsize=9)
    right.set_xlim(-2.0, 92.0)
    right.grid(True, alpha=0.3)
    if data.share is None:
        right.text(0.5, 0.5, "needs orders f_inf and f1\n(run with track_all_orders = true)",
                   transform=right.transAxes, ha="center", va="center", color="0.4")
    else:
        right.set_ylim(bottom=0.0)
        right.legend(fontsize=7)
    fig.suptitle(f"{table.path.name}: {format_material(table.material)}", fontsize=10)
    return fig
