"""The grids of an RGL measured-BSDF file (used by :mod:`vcavity.export.rgl`).

Unit-square coordinates of a direction: ``u = (sqrt(2 theta / pi), (phi + pi) / (2 pi))``
(Dupuy & Jakob 2018; Mitsuba ``measured.cpp``). Every grid here is over such
coordinates, with nodes at ``k / (n - 1)`` and bilinear interpolation between them, as a
reader interpolates (:func:`bilinear`). Plain NumPy; the normal distribution arrives as a
function of unit normals.
"""

from __future__ import annotations

import numpy as np

#: (phi, theta) nodes of ndf and vndf; N x N nodes of the colour grids
NDF_SHAPE = (64, 64)
SIGMA_SHAPE = (32, 64)
COLOUR_RESOLUTION = 128
#: radial midpoints of the isotropic projected-area rule, and (theta, phi) midpoints of
#: the anisotropic one
RADIAL_NODES = 4096
AREA_NODES = (1024, 256)
_SAMPLE_EPSILON = float(np.finfo(np.float32).eps) / 2   # readers clip samples to [eps, 1 - eps]


def u_to_theta(u):
    """Polar angle of the unit-square coordinate ``u``: ``theta = u^2 pi / 2``."""
    return np.square(u) * (np.pi / 2)


def theta_to_u(theta):
    """Inverse of :func:`u_to_theta`."""
    return np.sqrt(np.asarray(theta) * (2 / np.pi))


def u_to_phi(u):
    """Azimuth of the unit-square coordinate ``u``: ``phi = (2u - 1) pi``."""
    return (2 * np.asarray(u) - 1) * np.pi


def phi_to_u(phi):
    """Inverse of :func:`u_to_phi` (``phi`` in ``[-pi, pi]``)."""
    return (np.asarray(phi) + np.pi) / (2 * np.pi)


def direction(theta, phi):
    """Unit vectors of polar angle ``theta`` and azimuth ``phi`` (broadcast), shape (..., 3)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64))
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1)


def bilinear(grid, x, y):
    """A reader's bilinear interpolation of ``grid`` (H, W) at unit-square points ``(x, y)``."""
    h, w = grid.shape
    x = np.clip(x, 0.0, 1.0) * (w - 1)
    y = np.clip(y, 0.0, 1.0) * (h - 1)
    ix = np.minimum(np.asarray(x).astype(np.int64), w - 2)
    iy = np.minimum(np.asarray(y).astype(np.int64), h - 2)
    tx, ty = x - ix, y - iy
    top = grid[iy, ix] * (1 - tx) + grid[iy, ix + 1] * tx
    bottom = grid[iy + 1, ix] * (1 - tx) + grid[iy + 1, ix + 1] * tx
    return top * (1 - ty) + bottom * ty


def node_directions(shape):
    """Unit vectors at the nodes of a (phi, theta) grid of ``shape``, and the node coordinates."""
    u_y, u_x = np.meshgrid(np.linspace(0, 1, shape[0]), np.linspace(0, 1, shape[1]), indexing="ij")
    return direction(u_to_theta(u_x), u_to_phi(u_y)), u_x, u_y


def ndf_grid(ndf_of_m):
    """``ndf`` at the nodes of :data:`NDF_SHAPE` over ``(u_phi, u_theta)``, 1/sr."""
    m, _, _ = node_directions(NDF_SHAPE)
    return ndf_of_m(m.reshape(-1, 3)).reshape(NDF_SHAPE)


def projected_area_isotropic(ndf_of_m):
    """``sigma(theta_i) = ∫ ndf(m) max(0, wi.m) dω_m`` of an isotropic ``ndf``, as a function.

    Midpoints in ``u`` resolve sharp lobes (``theta = u^2 pi/2`` crowds nodes at the pole);
    the azimuthal integral is exact: ``∫ max(0, a + b cos phi) dphi`` is ``2 pi a`` when
    ``a >= b`` and ``2 (a phi0 + b sin phi0)``, ``phi0 = arccos(-a/b)``, otherwise. Divided by
    the same rule's ``∫ ndf cos theta_m dω_m`` (exactly 1), so quadrature error cancels to
    first order.
    """
    u = (np.arange(RADIAL_NODES) + 0.5) / RADIAL_NODES
    theta_m = u_to_theta(u)
    ndf = ndf_of_m(direction(theta_m, 0.0))
    weight = ndf * np.sin(theta_m) * (np.pi * u / RADIAL_NODES)  # dθ = π u du
    normalisation = 2 * np.pi * np.sum(weight * np.cos(theta_m))

    def sigma_of(theta_i):
        theta_i = np.asarray(theta_i, dtype=np.float64)[..., None]
        a = np.cos(theta_i) * np.cos(theta_m)
        b = np.sin(theta_i) * np.sin(theta_m)
        with np.errstate(divide="ignore", invalid="ignore"):
            phi0 = np.arccos(np.clip(-a / b, -1.0, 1.0))
        azimuthal = np.where(a >= b, 2 * np.pi * a, 2 * (a * phi0 + b * np.sin(phi0)))
        return np.sum(weight * azimuthal, axis=-1) / normalisation

    return sigma_of


def projected_area(ndf_of_m, wi):
    """``∫ ndf(m) max(0, wi.m) dω_m`` for unit vectors ``wi`` (K, 3) of any ``ndf``.

    Midpoint rule in ``(u_theta, phi)`` (:data:`AREA_NODES`), divided by the same rule's
    ``∫ ndf cos theta_m dω_m`` (exactly 1).
    """
    n_theta, n_phi = AREA_NODES
    u = (np.arange(n_theta) + 0.5) / n_theta
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    theta_m = u_to_theta(u)
    m = direction(theta_m[:, None], phi[None, :]).reshape(-1, 3)
    weight = (ndf_of_m(m).reshape(n_theta, n_phi) * (np.sin(theta_m) * np.pi * u / n_theta)[:, None]
              * (2 * np.pi / n_phi)).ravel()
    normalisation = np.sum(weight * m[:, 2])
    out = np.empty(len(wi))
    for start in range(0, len(wi), 64):
        out[start:start + 64] = np.maximum(wi[start:start + 64] @ m.T, 0.0) @ weight
    return out / normalisation


def vndf_slice(ndf_grid_values, wi):
    """Node values of the visible-normal density for incident ``wi`` over ``(u_phi, u_theta)``.

    Density per unit square = density per solid angle x ``|dω/du| = 2 pi^2 u_theta sin(theta_m)``
    (the constant is kept; readers normalise anyway).
    """
    m, u_x, _ = node_directions(NDF_SHAPE)
    return ndf_grid_values * np.maximum(m @ wi, 0.0) * 2 * np.pi ** 2 * u_x * np.sin(u_to_theta(u_x))


def colour_slice(evaluate, ndf, sigma, warp, wi):
    """``R(s) = f cos(theta_o) 4 sigma / ndf`` at the colour nodes, for incident ``wi``.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(wi, wo) -> f`` (1/sr) for arrays of directions.
    ndf, sigma : ndarray
        The file's grids, interpolated here exactly as a reader does.
    warp : vcavity.export.marginal2d.Marginal2D
        The reader's vndf warp of this slice.
    wi : ndarray (3,)
        Incident direction; isotropic files have ``phi_i = 0``, where the warp's azimuth
        (relative to ``phi_i``) is that of ``m``.
    """
    n = COLOUR_RESOLUTION
    s_y, s_x = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    s_x = np.clip(s_x, _SAMPLE_EPSILON, 1 - _SAMPLE_EPSILON)
    s_y = np.clip(s_y, _SAMPLE_EPSILON, 1 - _SAMPLE_EPSILON)
    u_x, u_y = warp.sample(s_x, s_y)
    m = direction(u_to_theta(u_x), u_to_phi(u_y))
    wo = 2 * (m @ wi)[..., None] * m - wi
    cos_o = wo[..., 2]
    up = cos_o > 0
    f = np.zeros(cos_o.shape)
    f[up] = evaluate(np.broadcast_to(wi, wo[up].shape), wo[up])
    phi_i = np.arctan2(wi[1], wi[0])
    sigma_i = bilinear(sigma, theta_to_u(np.arccos(np.clip(wi[2], -1, 1))), phi_to_u(phi_i))
    ndf_m = bilinear(ndf, u_x, u_y)
    with np.errstate(divide="ignore", invalid="ignore"):
        colour = np.where(up & (ndf_m > 0), f * cos_o * 4 * sigma_i / ndf_m, 0.0)
    return np.nan_to_num(colour, nan=0.0, posinf=0.0)
