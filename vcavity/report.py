"""Human-readable summaries of tables (used by ``vcavity run`` and ``vcavity info``)."""

from __future__ import annotations

import math

import numpy as np


def _order_label(k: int) -> str:
    return "f_inf" if k == 0 else f"f{k}"


def format_material(material: dict) -> str:
    """One line describing a material dict as stored in a table (``/material``).

    Generic over distributions and facet models: the distribution and facet names, each
    followed by its parameters as stored (isotropic ``alpha_x == alpha_y`` shown as
    ``alpha``). Needs no registry, so reading a table imports no JIT code.
    """
    params = {k: v for k, v in material.items() if k not in ("distribution", "facet")}
    if "alpha_x" in params and params.get("alpha_x") == params.get("alpha_y"):
        params = {"alpha": params.pop("alpha_x"), **{k: v for k, v in params.items() if k != "alpha_y"}}
    text = " ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in params.items())
    return f"{material.get('distribution', '?')}, {material.get('facet', '?')} facets: {text}".rstrip(": ")


def format_summary(table, verbose: bool = False) -> str:
    """Material, budget and per-direction energy balance of a :class:`~vcavity.io.table.Table`."""
    lines = [f"material: {format_material(table.material)}"]
    lines.append(
        f"sensor: {table.sensor.n_cells} cells ({table.sensor.resolution}x{table.sensor.resolution}), "
        f"seed {table.seed}, orders {', '.join(_order_label(int(k)) for k in table.order)}"
    )
    if verbose:
        lines.insert(0, f"table: {table.path} (format v{table.format_version}, vcavity {table.vcavity_version})")
        cfg = table.config if isinstance(table.config, dict) else {}
        sim = cfg.get("simulation", {})
        if sim:
            lines.append(f"bounce cap {sim.get('max_bounces')}, f_inf tracked: {sim.get('track_all_orders')}, "
                         f"config from {cfg.get('source', '?')}")
        t_run = table.attrs.get("compute_time_s")
        if t_run:
            total = int(np.sum(table.paths))
            lines.append(f"run time {float(t_run):.2f} s ({total / float(t_run) / 1e6:.2f} M paths/s), "
                         f"compile/load {float(table.attrs.get('compile_time_s', 0.0)):.2f} s")
    header = ["theta_i", "phi_i", "paths"] + [f"albedo {_order_label(int(k))}" for k in table.order] + [
        "absorbed", "truncated"]
    if np.any(table.degenerate > 0):
        header.append("degenerate")
    rows = []
    for d in range(len(table.theta_i)):
        row = [f"{math.degrees(table.theta_i[d]):.2f}", f"{math.degrees(table.phi_i[d]):.2f}", f"{int(table.paths[d]):,}"]
        row += [f"{table.albedo[d, j]:.6f}" for j in range(len(table.order))]
        row += [f"{table.absorbed[d]:.6f}", f"{table.truncated[d]:.2e}"]
        if np.any(table.degenerate > 0):
            row.append(f"{table.degenerate[d]:.2e}")
        rows.append(row)
    widths = [max(len(h), *(len(r[j]) for r in rows)) for j, h in enumerate(header)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    lines.extend("  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows)
    return "\n".join(lines)
