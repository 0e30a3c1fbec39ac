"""``--format albedo-lut --layout cycles``: the albedo tables on Blender Cycles' grids, in its order.

Cycles (``intern/cycles/app/cycles_precompute.cpp``, the tables in
``intern/cycles/scene/shader.tables``) ships ``table_ggx_E[1024]``, the directional albedo of
its single-scattering GGX, and ``table_ggx_Eavg[32]``, on node-centred grids:

- roughness ``r = sqrt(alpha)``, ``x = 0 .. 31``: ``r = clamp(x / 31, 1e-4, 1)`` (so
  ``alpha = 1e-8`` at ``x = 0``);
- ``mu = cos(theta_i)``, ``y = 0 .. 31``: ``mu = clamp(y / 31, 1e-4, 1)``;
- ``E[y * 32 + x]``: row-major with ``mu`` the row (C ``E[mu][r]``); ``E_avg[x]``.

A sweep gives the table when its ``alpha`` axis holds the 32 ``r^2`` and its
``theta_i_deg`` axis the 32 ``degrees(acos(mu))`` (``runs/sweep_albedo_lut_cycles.toml``),
each within :data:`NODE_TOLERANCE` in ``r`` and in ``mu``; other values of those axes are
not written. A node that is missing is refused, naming it.

``E_avg(r) = integral_0^1 2 mu E(mu, r) dmu`` by composite **Simpson** on the 32 nodes
``mu = y / 31`` (31 intervals: the 1/3 rule on the first 28, the 3/8 rule on the last
3), exact for ``E`` quadratic in ``mu`` and with an error ``O(h^4)`` (``h = 1/31``) for a
smooth one. The integrand ``2 mu E`` vanishes at ``mu = 0``, so the clamp of node 0 to
``1e-4`` does not enter. Why not the trapezoid rule: on Cycles' own shipped ``ggx_E``
these weights give Cycles' shipped ``ggx_Eavg`` (a Monte-Carlo integral over continuous
``mu``) within 1.9e-5 (max over the 32 values), the trapezoid rule only within 1.5e-4.
docs/exports.md, *Albedo LUT*, *Cycles layout*.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.export import ExportRefused, header_text
from vcavity.export.lut_common import c_array

N = 32
CLAMP = 1e-4
#: Largest |r - node| and |mu - node| accepted as the node (a sweep written with 10
#: significant digits is within 1e-9).
NODE_TOLERANCE = 1e-6
CONTAINERS = (".npz", ".npy", ".h")
QUADRATURE = ("E_avg = integral_0^1 2 mu E dmu by composite Simpson on the nodes mu = y/31: the 1/3 rule on "
              "[0, 28/31], the 3/8 rule on [28/31, 1] (2 mu E vanishes at mu = 0: node 0's clamp does not enter)")
LAYOUT = ("Cycles: E[y * 32 + x] (C E[mu][r], NumPy [y, x]); y: mu = clamp(y/31, 1e-4, 1); x: r = sqrt(alpha) = "
          "clamp(x/31, 1e-4, 1); E_avg[x]")


def nodes(n: int = N) -> tuple[np.ndarray, np.ndarray]:
    """``(r, mu)``: Cycles' node values, ``clamp(i / (n - 1), 1e-4, 1)`` each."""
    grid = np.clip(np.arange(n) / (n - 1), CLAMP, 1.0)
    return grid, grid.copy()


def simpson_weights(n: int = N) -> np.ndarray:
    """Weights ``w`` with ``sum_y w[y] g(y / (n - 1))`` ~ ``integral_0^1 g``: composite Simpson
    1/3 over the first ``n - 4`` intervals, 3/8 over the last 3 (``n - 1`` odd, ``n >= 4``)."""
    h = 1.0 / (n - 1)
    weights = np.zeros(n)
    for start in range(0, n - 4, 2):
        weights[start:start + 3] += np.array([1.0, 4.0, 1.0]) * h / 3.0
    weights[n - 4:] += np.array([1.0, 3.0, 3.0, 1.0]) * 3.0 * h / 8.0
    return weights


def average(values: np.ndarray) -> np.ndarray:
    """``E_avg[x] = integral 2 mu E dmu`` of a ``[y, x]`` table (module docstring)."""
    n = values.shape[0]
    mu = np.arange(n) / (n - 1)  # unclamped: 2 mu E is 0 at mu = 0
    return np.sum((simpson_weights(n) * 2.0 * mu)[:, None] * values, axis=0)


def average_stderr(stderr: np.ndarray) -> np.ndarray:
    """Standard error of :func:`average` for independent node errors (every incident
    direction has its own random streams)."""
    n = stderr.shape[0]
    mu = np.arange(n) / (n - 1)
    return np.sqrt(np.sum(((simpson_weights(n) * 2.0 * mu)[:, None] * stderr) ** 2, axis=0))


def _match(values: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """Position in ``values`` of each target (within the tolerance), and the missing targets."""
    found, missing = np.zeros(targets.size, dtype=np.int64), []
    for i, target in enumerate(targets):
        near = np.flatnonzero(np.abs(values - target) <= NODE_TOLERANCE)
        if near.size == 0:
            missing.append(i)
        else:
            found[i] = near[np.argmin(np.abs(values[near] - target))]
    return found, missing


def _listed(label: str, missing: list[int], needed: list[float], axis: str) -> str:
    shown = ", ".join(f"{i} ({axis} = {needed[i]:.10g})" for i in missing[:4])
    more = f", and i = {', '.join(str(i) for i in missing[4:])}" if len(missing) > 4 else ""
    return f"{len(missing)} {label} node(s) i = {shown}{more}"


def locate(alpha: np.ndarray, theta_i_deg: np.ndarray, shown: str) -> tuple[np.ndarray, np.ndarray]:
    """Positions on the sweep's ``alpha`` and ``theta_i_deg`` axes of the 32 ``r`` and 32
    ``mu`` nodes.

    Raises
    ------
    ExportRefused
        One line naming every missing node (``i``, and the axis value it needs).
    """
    r, mu = nodes()
    r_index, r_missing = _match(np.sqrt(np.asarray(alpha, dtype=np.float64)), r)
    mu_index, mu_missing = _match(np.cos(np.radians(np.asarray(theta_i_deg, dtype=np.float64))), mu)
    if r_missing or mu_missing:
        parts = []
        if r_missing:
            parts.append(_listed("r", r_missing, list(r * r), "alpha"))
        if mu_missing:
            parts.append(_listed("mu", mu_missing, [math.degrees(math.acos(m)) for m in mu], "theta_i_deg"))
        raise ExportRefused(f"sweep {shown}: --layout cycles needs alpha = r^2 at r = clamp(i/31, 1e-4, 1) and "
                            f"theta_i_deg = degrees(acos(mu)) at mu = clamp(i/31, 1e-4, 1), i = 0 .. 31 (as "
                            f"runs/sweep_albedo_lut_cycles.toml); missing: {'; '.join(parts)}")
    return r_index, mu_index


def npz_arrays(lut) -> dict:
    """The ``.npz`` arrays: the axes (node values ``r``, ``alpha``, ``mu``, ``theta_i_deg``
    as simulated), ``paths[y, x]``, the tables (``[y, x]`` and ``[x]``), metadata strings."""
    arrays = {**lut.axes, "paths": lut.paths, **lut.tables}
    arrays.update({key: np.array(value) for key, value in lut.metadata.items()})
    return arrays


def npy_array(lut) -> np.ndarray:
    """The ``.npy`` array: the E tables, shape (n, 32, 32) ``[table, y, x]``, in the order of
    the ``tables`` metadata (without ``--orders``: E_f1, then E of ``--order``), so that
    ``array[k].ravel()`` is Cycles' ``data[y * 32 + x]`` of table ``k``."""
    return np.stack([v for name, v in lut.tables.items() if v.ndim == 2 and not name.endswith("_stderr")])


def c_header(lut) -> str:
    """The ``.h`` text: metadata and axes as comments, sizes as macros, ``static const float``
    arrays ``vcavity_cycles_<table>[1024]`` (32 values a line: one mu row) and ``[32]``."""
    meta = lut.metadata
    lines = ["/* Albedo look-up tables for energy compensation (Kulla & Conty 2017) in Blender Cycles'",
             f" * layout (table_ggx_E, table_ggx_Eavg), written by vcavity {meta['vcavity_version']}",
             " * (vcavity export --format albedo-lut --layout cycles).", " *"]
    lines += [f" * {key}: {header_text(value).replace('*/', '* /')}" for key, value in meta.items()]
    lines += [" * theta_i_deg of each mu node, as simulated: "
              + ", ".join(repr(float(t)) for t in lut.axes["theta_i_deg"]),
              " * alpha of each r node, as simulated: " + ", ".join(repr(float(a)) for a in lut.axes["alpha"]),
              " */", "#ifndef VCAVITY_ALBEDO_LUT_CYCLES_H", "#define VCAVITY_ALBEDO_LUT_CYCLES_H", "",
              f"#define VCAVITY_CYCLES_N {N}", ""]
    text = "\n".join(lines) + "\n"
    text += c_array("vcavity_cycles_r", lut.axes["r"], "[VCAVITY_CYCLES_N]")
    text += c_array("vcavity_cycles_mu", lut.axes["mu"], "[VCAVITY_CYCLES_N]")
    for name, values in lut.tables.items():
        if values.ndim == 2:
            text += "\n" + c_array(f"vcavity_cycles_{name}", values.ravel(),
                                   "[VCAVITY_CYCLES_N * VCAVITY_CYCLES_N]", per_line=N)
        else:
            text += "\n" + c_array(f"vcavity_cycles_{name}", values, "[VCAVITY_CYCLES_N]")
    return text + "\n#endif /* VCAVITY_ALBEDO_LUT_CYCLES_H */\n"
