"""Human-readable summaries of tables and checkpoints (used by ``vcavity run`` and ``vcavity info``)."""

from __future__ import annotations

import math

import numpy as np

from vcavity.io.schema import order_name


def _angle(degrees: float) -> str:
    """An angle for a table column: 2 decimals, or 3 significant digits when that would be
    wider than 9 characters (a table may hold any finite azimuth), so columns stay narrow."""
    text = f"{degrees:.2f}"
    return text if len(text) <= 9 else f"{degrees:.3g}"


def _number(value) -> float | None:
    """A numeric attribute as float, None when absent or not a number (corrupt tables)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)


def format_material(material: dict) -> str:
    """One line describing a material dict as stored in a table (``/material``).

    Generic over distributions and facet models: the distribution and facet names, each
    followed by its parameters as stored (isotropic ``alpha_x == alpha_y`` shown as
    ``alpha``). Needs no registry, so reading a table imports no JIT code.
    """
    params = {k: v for k, v in material.items() if k not in ("microsurface", "distribution", "facet")}
    if "alpha_x" in params and params.get("alpha_x") == params.get("alpha_y"):
        params = {"alpha": params.pop("alpha_x"), **{k: v for k, v in params.items() if k != "alpha_y"}}
    text = " ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in params.items())
    # tables without the key are V-cavity tables (the key is stored only for Smith)
    surface = material.get("microsurface", "v-cavity")
    return (f"{surface} microsurface, {material.get('distribution', '?')}, {material.get('facet', '?')} facets: "
            f"{text}").rstrip(": ")


def _estimator_line(table) -> str:
    """How the table was estimated: estimator, analytic orders, fold, target."""
    estimator = table.estimator
    text = f"estimator {estimator}"
    if table.deterministic:
        return (text + " (deterministic: every order from the every-order model of specular V-cavities, "
                "no path traced; brdf_stderr and rel. error are the model's error estimates)")
    if table.order_source is not None and np.any(table.order_source == 1):
        smith = (table.material or {}).get("microsurface") == "smith"
        model = "height-correlated Smith" if smith else "V-cavity"
        text += f" (f1 is analytic: the exact {model} single-bounce model; orders >= 2 simulated)"
    folded = table.folded if table.folded is not None else np.zeros(len(table.theta_i))
    if np.all(folded == 1):
        text += "; folded about the plane of incidence"
    elif np.any(folded == 1):
        text += f"; folded about the plane of incidence for {int(np.sum(folded == 1))} of {folded.size} directions"
    target = table.attrs.get("target_error")
    if isinstance(target, float) and math.isfinite(target):
        text += f"; target error {target:g}"
    return text


def _device_line(table) -> str:
    """Where the walk ran: ``device: cpu``, or the GPU with its CUDA driver and runtime."""
    device = str(table.attrs.get("device", "cpu"))  # tables before the attribute: the CPU
    if device == "cpu":
        return "device: cpu"
    name, driver, runtime = (str(table.attrs.get(key, "?")) for key in (
        "device_name", "cuda_driver_version", "cuda_runtime_version"))
    if name == driver == runtime == "simulator":
        return f"device: {device} (numba's CUDA simulator)"
    return f"device: {device} ({name}, CUDA driver {driver}, runtime {runtime})"


def describe_checkpoint(path) -> str:
    """What ``vcavity info`` prints for a checkpoint file."""
    from vcavity.io import checkpoint

    summary = checkpoint.describe(path)
    done, planned = summary["paths_done"], summary["paths_planned"]
    source = summary["config"].get("source", "?")
    share = 100.0 * done / planned if planned else 0.0
    return (f"checkpoint: {path} (partial run of {source}): {done:,} of {planned:,} paths done ({share:.1f} %), "
            f"{summary['compute_time_s']:.1f} s traced; continue with: vcavity run ... --resume")


def format_summary(table, verbose: bool = False) -> str:
    """Material, budget and per-direction energy balance of a :class:`~vcavity.io.table.Table`."""
    lines = [f"material: {format_material(table.material)}"]
    lines.append(
        f"sensor: {table.sensor.n_cells} cells ({table.sensor.resolution}x{table.sensor.resolution}), "
        f"seed {table.seed}, orders {', '.join(order_name(int(k)) for k in table.order)}"
    )
    lines.append(_estimator_line(table))
    if verbose:
        lines.insert(0, f"table: {table.path} (format v{table.format_version}, vcavity {table.vcavity_version})")
        cfg = table.config if isinstance(table.config, dict) else {}
        sim = cfg.get("simulation", {})
        if isinstance(sim, dict) and sim:
            lines.append(f"bounce cap {sim.get('max_bounces')}, f_inf tracked: {sim.get('track_all_orders')}, "
                         f"config from {cfg.get('source', '?')}")
        t_run = _number(table.attrs.get("compute_time_s"))
        t_models = _number(table.attrs.get("model_compile_time_s")) or 0.0  # 0 without models, or older tables
        if t_run and t_run > 0 and table.deterministic:
            lines.append(f"model time {t_run:.2f} s" + (f", model compile/load {t_models:.2f} s" if t_models else ""))
        elif t_run and t_run > 0:
            total = int(np.sum(table.paths))
            t_compile = _number(table.attrs.get("compile_time_s")) or 0.0
            lines.append(f"run time {t_run:.2f} s ({total / t_run / 1e6:.2f} M paths/s), "
                         f"compile/load {t_compile:.2f} s"
                         + (f", model compile/load {t_models:.2f} s" if t_models else ""))
        lines.append(_device_line(table))
    with_error = table.relative_error is not None and np.any(np.isfinite(table.relative_error))
    header = ["theta_i", "phi_i", "paths"] + [f"albedo {order_name(int(k))}" for k in table.order] + [
        "absorbed", "truncated"] + (["rel. error f_inf"] if with_error else [])
    if np.any(table.degenerate > 0):
        header.append("degenerate")
    rows = []
    for d in range(len(table.theta_i)):
        row = [_angle(math.degrees(table.theta_i[d])), _angle(math.degrees(table.phi_i[d])), f"{int(table.paths[d]):,}"]
        row += [f"{table.albedo[d, j]:.6f}" for j in range(len(table.order))]
        row += [f"{table.absorbed[d]:.6f}", f"{table.truncated[d]:.2e}"]
        if with_error:
            row.append(f"{table.relative_error[d]:.2e}" + ("" if table.target_reached is None or
                                                            table.target_reached[d] != 0 else " (cap)"))
        if np.any(table.degenerate > 0):
            row.append(f"{table.degenerate[d]:.2e}")
        rows.append(row)
    widths = [max(len(h), *(len(r[j]) for r in rows)) for j, h in enumerate(header)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    lines.extend("  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in rows)
    return "\n".join(lines)
