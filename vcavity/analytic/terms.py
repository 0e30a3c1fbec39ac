"""Jitted building blocks of the analytic models: D, Smith Lambda, G2 and Fresnel, with
the distribution and the masking chosen by integer codes (physics.md sec. 2-4).

The distribution kind is the ``KIND`` of a :mod:`vcavity.microfacet` module and
``params`` its ``make_params`` array (see :func:`vcavity.simulate.distribution_params`).
All functions are ``numba.njit(cache=True)`` on floats; vectors are passed as three
floats; all directions point away from the surface (physics.md sec. 1).
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._jit import njit

from vcavity.facet.fresnel import fresnel_dielectric, fresnel_transmittance, fresnel_transmittance_array
from vcavity.microfacet import beckmann, gaussian, ggx, phong
from vcavity.microfacet.common import g2_smith_height_correlated, g2_smith_separable, g2_vcavity

#: Masking-shadowing codes (physics.md sec. 3): V-cavity min of G1 (H eq. 49, IL eq. 14),
#: Smith separable (H eq. 98), Smith height-correlated (H eq. 99).
VCAVITY = 0
SMITH = 1
SMITH_HEIGHT_CORRELATED = 2
MASKING_CODES = {"vcavity": VCAVITY, "smith": SMITH, "smith-hc": SMITH_HEIGHT_CORRELATED}


@njit(cache=True)
def distribution_D(kind, mx, my, mz, params):
    """``D(m)`` of the distribution ``kind`` (H eq. 82, 85; W eq. 30; IL eq. 13)."""
    if kind == beckmann.KIND:
        return beckmann.D(mx, my, mz, params)
    elif kind == ggx.KIND:
        return ggx.D(mx, my, mz, params)
    elif kind == phong.KIND:
        return phong.D(mx, my, mz, params)
    return gaussian.D(mx, my, mz, params)


@njit(cache=True)
def sample_normal(kind, u1, u2, params):
    """The distribution's sampling map ``(u1, u2) -> m`` with pdf ``D(m)(m.n)`` (sec. 2)."""
    if kind == beckmann.KIND:
        return beckmann.sample_normal(u1, u2, params)
    elif kind == ggx.KIND:
        return ggx.sample_normal(u1, u2, params)
    elif kind == phong.KIND:
        return phong.sample_normal(u1, u2, params)
    return gaussian.sample_normal(u1, u2, params)


@njit(cache=True)
def smith_lambda(kind, vx, vy, vz, params, walter_fit):
    """Smith ``Lambda(v)`` (H eq. 69, 72, 80); Beckmann with ``walter_fit``: W eq. 27.

    Phong uses Walter's Beckmann-based approximation (W sec. 5.2); the Gaussian returns
    ``inf`` off the normal (its Smith Lambda diverges, see microfacet/gaussian.py).
    """
    if kind == beckmann.KIND:
        if walter_fit:
            return beckmann.smith_lambda_walter_fit(vx, vy, vz, params)
        return beckmann.smith_lambda(vx, vy, vz, params)
    elif kind == ggx.KIND:
        return ggx.smith_lambda(vx, vy, vz, params)
    elif kind == phong.KIND:
        return phong.smith_lambda(vx, vy, vz, params)
    return gaussian.smith_lambda(vx, vy, vz, params)


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


@njit(cache=True)
def facet_fresnel(cos_theta, eta, mirror):
    """Facet reflectance: 1 for a mirror, else the dielectric F (W eq. 22, IL eq. 7)."""
    if mirror:
        return 1.0
    return fresnel_dielectric(cos_theta, eta)


@njit(cache=True)
def facet_transmittance(cos_theta, eta):
    """``T = 1 - F`` (W eq. 22), computed as a sum of positive terms (facet/fresnel.py)."""
    return fresnel_transmittance(cos_theta, eta)


#: Intervals of the transmittance table (:func:`accurate_transmittance_table`).
TRANSMITTANCE_TABLE_SIZE = 4096


def _transmittance_coefficients(eta, n):
    """Per interval ``[k/n, (k+1)/n]`` the cubic through T (W eq. 22) at the 4 nearest nodes.

    Row ``k`` holds ``(a0, a1, a2, a3)`` with ``T ~ a0 + a1 s + a2 s^2 + a3 s^3``,
    ``s = c n - k`` in ``[0, 1]`` (4-point Lagrange, shifted one-sided at both ends).
    """
    nodes = fresnel_transmittance_array(np.arange(n + 1) / n, eta)
    first = np.clip(np.arange(n) - 1, 0, n - 3)  # leftmost of the 4 nodes
    offset = np.arange(n) - first  # s = 0 is node first + offset (0, 1 or 2)
    values = nodes[first[:, None] + np.arange(4)[None, :]]  # (n, 4)
    coefficients = np.empty((n, 4))
    for shift in (0, 1, 2):
        rows = offset == shift
        vandermonde = np.vander(np.arange(4.0) - shift, 4, increasing=True)
        coefficients[rows] = np.linalg.solve(vandermonde, values[rows].T).T
    return coefficients


def accurate_transmittance_table(eta, tolerance=1e-11):
    """Cubic table of ``T(c)`` for :func:`table_transmittance`, or an empty one.

    The table is used when it is within ``tolerance`` of the closed form at every
    interval midpoint and quarter point; otherwise (near ``eta = 1`` and at large eta,
    where T varies on a scale below the grid step) an empty ``(0, 4)`` array tells
    :func:`table_transmittance` to use the closed form, as does ``eta == 1`` (where the
    closed form returns 1 at once).
    """
    if eta == 1.0:
        return np.empty((0, 4))
    n = TRANSMITTANCE_TABLE_SIZE
    table = _transmittance_coefficients(float(eta), n)
    probes = (np.arange(n)[:, None] + np.array([0.25, 0.5, 0.75])[None, :]).ravel() / n
    exact = fresnel_transmittance_array(probes, float(eta))
    k = np.minimum((probes * n).astype(np.int64), n - 1)
    t = probes * n - k
    approx = ((table[k, 3] * t + table[k, 2]) * t + table[k, 1]) * t + table[k, 0]
    worst = np.max(np.abs(approx - exact))
    if worst <= tolerance:
        return table
    return np.empty((0, 4))


@njit(cache=True)
def table_transmittance(c, table, eta):
    """``T(c)`` (W eq. 22) from :func:`accurate_transmittance_table`, else the closed form.

    T is smooth on ``[0, 1]`` for moderate eta, so the cubic error is ``O(h^4)``: below
    1e-11 where the table is used (checked at construction); about 3x faster than the
    closed form in the body-integral loops.
    """
    n = table.shape[0]
    if n == 0:
        return fresnel_transmittance(c, eta)
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


@njit(cache=True)
def d_many(kind, m, params):
    """``D`` over the rows of an ``(N, 3)`` array of normals."""
    out = np.empty(m.shape[0])
    for k in range(m.shape[0]):
        out[k] = distribution_D(kind, m[k, 0], m[k, 1], m[k, 2], params)
    return out


@njit(cache=True)
def smith_lambda_many(kind, v, params, walter_fit):
    """Smith ``Lambda`` over the rows of an ``(N, 3)`` array of directions."""
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        out[k] = smith_lambda(kind, v[k, 0], v[k, 1], v[k, 2], params, walter_fit)
    return out
