"""Human summary of a sweep file (``vcavity info`` on a sweep): plain Python, no Numba."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np

from vcavity.io.schema import order_name

#: Rows of the albedo table printed before the rest is elided.
MAX_ROWS = 200


def _value(v) -> str:
    return f"{v:g}" if isinstance(v, (int, float)) else str(v)


def sweep_device(sweep) -> str:
    """Where a sweep's walks ran, ``"cpu"`` or ``"cuda"``: its root attribute ``device``; in a
    file written before it, ``simulation.device`` of its overrides or spec, else ``"cpu"``."""
    if "device" in sweep.attrs:
        return str(sweep.attrs["device"])
    try:
        written = json.loads(sweep.attrs.get("spec") or "{}").get("base", {}).get("simulation", {}).get("device")
        return str(json.loads(sweep.attrs.get("overrides") or "{}").get("simulation.device", written or "cpu"))
    except (ValueError, AttributeError):  # not JSON, or not of a sweep's shape
        return "cpu"


def format_sweep_summary(sweep, max_rows: int = MAX_ROWS) -> str:
    """Axes with their values, points done / planned and the albedo of every direction.

    Parameters
    ----------
    sweep : vcavity.io.sweep_table.SweepData
        As read by :func:`vcavity.io.sweep_table.open_sweep`.
    max_rows : int
        Rows of the albedo table shown; the rest is counted, not printed.
    """
    attrs = sweep.attrs
    done = sweep.data["done"]
    n_points = int(done.size)
    shared = " ".join(f"{k}={_value(v)}" for k, v in sweep.material.items())
    lines = [f"sweep: {sweep.path} (format vcavity-sweep, vcavity {attrs.get('vcavity_version')}), "
             f"spec from {attrs.get('source', '?')}",
             f"shared by every point: {shared or 'nothing'}"
             + "".join(f"; {k} = {_value(v)}" for k, v in sweep.scalars.items())]
    for axis in sweep.axes:
        units = "" if axis.units in (None, "1") else f" ({axis.units})"
        role = "" if axis.name in sweep.point_axes else ", incident direction"
        lines.append(f"axis {axis.name}{units}{role}: {', '.join(_value(v) for v in axis.values)}"
                     + "".join(f"; sets {key} = {', '.join(_value(v) for v in values)}"
                               for key, values, *_ in axis.paired))
    resolution = attrs.get("sensor_resolution")
    lines.append(f"points: {sweep.n_done()} of {n_points} done ({math.prod(sweep.shape):,} grid positions); "
                 f"sweep seed {attrs.get('seed')}, estimator {attrs.get('estimator')}, sensor "
                 f"{resolution}x{resolution}, orders {', '.join(order_name(int(k)) for k in sweep.order)}; "
                 f"device {sweep_device(sweep)}")
    if sweep.rejected:  # marked done, but their bytes do not match their checksum
        lines.append(f"{len(sweep.rejected)} point(s) marked done fail their checksum (a write cut short or "
                     "changed bytes): read as pending; sweep --resume runs them again")
    header = [a.name for a in sweep.axes] + ["paths"] + [f"albedo {order_name(int(k))}" for k in sweep.order] \
        + ["absorbed", "truncated"]
    rows = []
    point_positions = [i for i, a in enumerate(sweep.axes) if a.name in sweep.point_axes]
    total = math.prod(sweep.shape)
    for where in itertools.islice(np.ndindex(*sweep.shape), max_rows):
        row = [_value(a.values[i]) for a, i in zip(sweep.axes, where)]
        if not done[tuple(where[p] for p in point_positions)]:
            rows.append(row + ["pending"] + [""] * (len(header) - len(row) - 1))
            continue
        row.append(f"{int(sweep.data['paths'][where]):,}")
        row += [f"{x:.6f}" for x in sweep.data["albedo"][where]]
        row += [f"{sweep.data['absorbed'][where]:.6f}", f"{sweep.data['truncated'][where]:.2e}"]
        rows.append(row)
    widths = [max(len(h), *(len(r[j]) for r in rows)) for j, h in enumerate(header)]
    lines.append("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    lines.extend("  ".join(c.rjust(w) for c, w in zip(r, widths)).rstrip() for r in rows)
    if total > max_rows:
        lines.append(f"... {total - max_rows:,} more rows (all of them: "
                     f"xarray.open_dataset({str(sweep.path)!r}, engine='h5netcdf').albedo)")
    return "\n".join(lines)


__all__ = ["MAX_ROWS", "format_sweep_summary", "sweep_device"]
