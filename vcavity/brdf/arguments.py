"""The table API's arguments checked and normalised: directions and uniforms (docs/table-api.md).

Directions of shape ``(..., 3)`` are normalised without under- or overflow; a NaN or
infinite component, or a uniform outside ``[0, 1)``, raises ``ValueError`` naming the
argument, the index and the value (a silent 0 or NaN would hide a caller's bug in a
render). Plain NumPy, used by :class:`vcavity.brdf.table_brdf.TableBRDF`.
"""

from __future__ import annotations

import numpy as np


def _unit(v, name="directions"):
    """``(..., 3)`` float64 unit vectors (a zero vector stays zero: below the horizon).

    Each vector is divided by its largest absolute component before its length is taken,
    so a denormal or a huge non-unit vector (1e-320 or 1e300 components) gets the value
    at its direction instead of a length that under- or overflows to 0 or inf.

    Raises
    ------
    ValueError
        The shape is not ``(..., 3)``, or a component is NaN or infinite (a caller's bug:
        a silent 0 or NaN result would hide it in a render; docs/table-api.md).
    """
    v = np.asarray(v, dtype=np.float64)
    if v.ndim < 1 or v.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got {v.shape}")
    finite = np.isfinite(v).all(axis=-1)
    if not finite.all():
        index = np.unravel_index(np.flatnonzero(~finite.ravel())[0], finite.shape)
        raise ValueError(f"{name}[{', '.join(str(int(i)) for i in index)}] = {v[index].tolist()}: "
                         "directions must be finite")
    scale = np.max(np.abs(v), axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        scaled = np.where(scale > 0.0, v / scale, 0.0)  # largest component +-1: no under/overflow
        unit = np.where(scale > 0.0, scaled / np.sqrt(np.sum(scaled * scaled, axis=-1, keepdims=True)), 0.0)
        length = np.sqrt(np.sum(v * v, axis=-1, keepdims=True))
    # unit to rounding: left as given, so that normalising is idempotent and pdf(wi, wo) of
    # a sampled wo reproduces the pdf sample returned bit for bit
    return np.where(np.abs(length - 1.0) <= 1e-14, v, unit)


def _uniform(name, u):
    """``u`` as float64, refused unless every value is in ``[0, 1)`` (NaN included)."""
    u = np.asarray(u, dtype=np.float64)
    bad = ~((u >= 0.0) & (u < 1.0))
    if bad.any():
        index = np.unravel_index(np.flatnonzero(bad.ravel())[0], u.shape)
        where = f"[{', '.join(str(int(i)) for i in index)}]" if u.ndim else ""
        raise ValueError(f"{name}{where} = {u[index].item()!r}: must be in [0, 1)")
    return u


def _directions(wi, wo):
    """Broadcast, normalise and flatten two direction arrays: (M, 3), (M, 3), shape."""
    wi, wo = np.broadcast_arrays(_unit(wi, "wi"), _unit(wo, "wo"))
    shape = wi.shape[:-1]
    return wi.reshape(-1, 3), wo.reshape(-1, 3), shape
