"""Jitted building blocks of the analytic models: Smith Lambda, G2, a fast transmittance
table (physics.md sec. 2-4).

D, the samplers and Smith Lambda of a distribution come from
:mod:`vcavity.microfacet.registry`, reflectance and transmittance of a facet model from
:mod:`vcavity.facet.registry` (a run-time ``kind`` dispatches over the registered
modules, so one compiled model function serves every material). All directions point away
from the surface (physics.md sec. 1) and are passed as three floats.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet import registry as facets
from vcavity.microfacet import beckmann
from vcavity.microfacet import registry as distributions
from vcavity.microfacet.common import g2_smith_height_correlated, g2_smith_separable, g2_vcavity

#: Masking-shadowing codes (physics.md sec. 3): V-cavity min of G1 (H eq. 49, IL eq. 14),
#: Smith separable (H eq. 98), Smith height-correlated (H eq. 99).
VCAVITY = 0
SMITH = 1
SMITH_HEIGHT_CORRELATED = 2
MASKING_CODES = {"vcavity": VCAVITY, "smith": SMITH, "smith-hc": SMITH_HEIGHT_CORRELATED}


@njit(cache=True, inline="always")
def smith_lambda(kind, vx, vy, vz, params, walter_fit):
    """Smith ``Lambda(v)`` of distribution ``kind`` (H eq. 69, 72, 80; see each module).

    ``walter_fit`` (Beckmann only, checked by the caller): Walter's rational fit, W eq. 27.
    """
    if walter_fit:
        return beckmann.smith_lambda_walter_fit(vx, vy, vz, params)
    return distributions.smith_lambda(kind, vx, vy, vz, params)


@njit(cache=True)
def smith_lambda_rows(kind, v, params, walter_fit):
    """:func:`smith_lambda` over the rows of an ``(N, 3)`` array of directions."""
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        out[k] = smith_lambda(kind, v[k, 0], v[k, 1], v[k, 2], params, walter_fit)
    return out


@njit(cache=True)
def g2(masking, ix, iy, iz, ox, oy, oz, mx, my, mz, lambda_i, lambda_o):
    """Joint masking-shadowing ``G2(i, o, m)`` with the sidedness factors (physics.md sec. 3).

    ``chi+(i.m) chi+(o.m)`` times: ``min(G1_V(i, m), G1_V(o, m))`` (IL eq. 14) for
    ``VCAVITY``, ``1/((1 + Lambda_i)(1 + Lambda_o))`` (H eq. 98) for ``SMITH``,
    ``1/(1 + Lambda_i + Lambda_o)`` (H eq. 99) for ``SMITH_HEIGHT_CORRELATED``.
    """
    if ix * mx + iy * my + iz * mz <= 0.0 or ox * mx + oy * my + oz * mz <= 0.0:
        return 0.0
    if masking == VCAVITY:
        return g2_vcavity(ix, iy, iz, ox, oy, oz, mx, my, mz)
    if masking == SMITH:
        return g2_smith_separable(lambda_i, lambda_o)
    return g2_smith_height_correlated(lambda_i, lambda_o)


#: Intervals of the transmittance table (:func:`accurate_transmittance_table`).
TRANSMITTANCE_TABLE_SIZE = 4096


@njit(cache=True)
def _transmittance_rows(facet_kind, cosines, facet_data):
    """The facet's transmittance at each cosine (1-D array)."""
    out = np.empty(cosines.shape[0])
    for k in range(cosines.shape[0]):
        out[k] = facets.transmittance(facet_kind, cosines[k], facet_data)
    return out


def _transmittance_coefficients(facet_kind, facet_data, n):
    """Per interval ``[k/n, (k+1)/n]`` the cubic through T at the 4 nearest nodes.

    Row ``k`` holds ``(a0, a1, a2, a3)`` with ``T ~ a0 + a1 s + a2 s^2 + a3 s^3``,
    ``s = c n - k`` in ``[0, 1]`` (4-point Lagrange, shifted one-sided at both ends).
    """
    nodes = _transmittance_rows(facet_kind, np.arange(n + 1) / n, facet_data)
    first = np.clip(np.arange(n) - 1, 0, n - 3)  # leftmost of the 4 nodes
    offset = np.arange(n) - first  # s = 0 is node first + offset (0, 1 or 2)
    values = nodes[first[:, None] + np.arange(4)[None, :]]  # (n, 4)
    coefficients = np.empty((n, 4))
    for shift in (0, 1, 2):
        rows = offset == shift
        vandermonde = np.vander(np.arange(4.0) - shift, 4, increasing=True)
        coefficients[rows] = np.linalg.solve(vandermonde, values[rows].T).T
    return coefficients


def accurate_transmittance_table(facet_kind, facet_data, has_specular, tolerance=1e-11):
    """Cubic table of the facet's ``T(c)`` for :func:`table_transmittance`, or an empty one.

    The table is used when it is within ``tolerance`` of the closed form at every
    interval midpoint and quarter point; otherwise (for the IL facet: near ``eta = 1``
    and at large eta, where T varies on a scale below the grid step) an empty ``(0, 4)``
    array tells :func:`table_transmittance` to use the closed form, as does a facet
    without a specular part (an IL facet with ``eta == 1``: ``T == 1`` at once).
    """
    if not has_specular:
        return np.empty((0, 4))
    n = TRANSMITTANCE_TABLE_SIZE
    table = _transmittance_coefficients(facet_kind, facet_data, n)
    probes = (np.arange(n)[:, None] + np.array([0.25, 0.5, 0.75])[None, :]).ravel() / n
    exact = _transmittance_rows(facet_kind, probes, facet_data)
    k = np.minimum((probes * n).astype(np.int64), n - 1)
    t = probes * n - k
    approx = ((table[k, 3] * t + table[k, 2]) * t + table[k, 1]) * t + table[k, 0]
    worst = np.max(np.abs(approx - exact))
    if worst <= tolerance:
        return table
    return np.empty((0, 4))


@njit(cache=True, inline="always")
def table_transmittance(c, table, facet_kind, facet_data):
    """The facet's ``T(c)`` from :func:`accurate_transmittance_table`, else its closed form.

    The IL facet's T (W eq. 22) is smooth on ``[0, 1]`` for moderate eta, so the cubic
    error is ``O(h^4)``: below 1e-11 where the table is used (checked at construction);
    faster than the closed form in the body-integral loops (docs/performance.md).
    """
    n = table.shape[0]
    if n == 0:
        return facets.transmittance(facet_kind, c, facet_data)
    x = c * n
    k = int(x)
    if k >= n:
        k = n - 1
    elif k < 0:
        k = 0
    s = x - k
    return ((table[k, 3] * s + table[k, 2]) * s + table[k, 1]) * s + table[k, 0]


@njit(cache=True)
def normalize(x, y, z):
    """``(x, y, z)/|(x, y, z)|`` and the norm; ``(0, 0, 0, 0)`` for the zero vector."""
    norm = math.sqrt(x * x + y * y + z * z)
    if norm <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return x / norm, y / norm, z / norm, norm
