"""Order-1 and order-2 albedos of Lambertian facets (``eta = 1``) from 2-D view factors.

Our own derivation (2-D radiative exchange between infinitely long strips, e.g. Siegel &
Howell, "Thermal radiation heat transfer", ch. 4-5; physics.md sec. 8 "crossed strings").

Geometry of one groove (cross-section, groove frame): vertex ``V``, walls ``A`` (normal
``m``, the left wall) and ``B`` (normal ``m'``), each of length ``L = sec θ_m``, opening
angle ``Φ = π - 2 θ_m`` at ``V``; the opening ``O`` has width 2. A point of a wall is
given by its distance ``a`` (on A) or ``b`` (on B) from ``V``.

- A 3-D cosine-weighted (Lambertian) direction projects on the cross-section with the
  2-D density ``½ cos ϑ dϑ``, so the point-to-strip view factor is
  ``½ (sin ϑ_2 - sin ϑ_1)`` and the point-to-point density is the kernel
  ``K(a, b) db = cos ϑ_a cos ϑ_b/(2 r) db = a b sin²Φ/(2 r³) db``,
  ``r² = a² + b² - 2ab cos Φ``.
- From the point ``a`` on A the opening is seen between the direction of A's rim (along
  A, ``sin ϑ = 1``) and that of B's rim: ``F_O(a) = ½ (1 - (L cos Φ - a)/D(a))``,
  ``D(a) = sqrt(L² + a² - 2 a L cos Φ)`` (``D(L) = 2``); ``F_B(a) = 1 - F_O(a)``.
- Parallel light: rays entering at ``x' ∈ (-1, 1)`` along ``d`` reach A iff they pass
  left of ``V``, ``x' < x_V = T d_x/d_z``, so A receives ``P_A = (clip(x_V) + 1)/2`` of
  the paths, and the first hits are uniform over the lit interval ``[a_0, L]`` (the map
  ``x' -> a`` is affine; ``a_0 = 0`` unless every ray reaches A).
- Order 1: ``kd P_A mean_{[a_0, L]} F_O``, closed form
  ``mean = ½ [1 - (D(a_0) - 2)/(L - a_0)]`` (``= cos θ_m`` at ``a_0 = 0``: the crossed
  strings value of physics.md sec. 8).
- Order 2: ``kd² P_A mean_{[a_0, L]} g``, ``g(a) = ∫_0^L K(a, b) F_O(b) db`` (composite
  Gauss-Legendre on panels graded geometrically about ``b = a``, where the kernel peaks
  with width ``a sin Φ``; checked against the closed form ``∫ K db = F_B(a)``).
- Same for B with ``d_x -> -d_x``; then integrate over normals with
  :func:`tests.reference.materials.normal_quadrature` (weights ``D(m)(m.n) dω_m``).

:func:`groove_monte_carlo` is a plain NumPy random walk in one groove's cross-section,
used only to check the view-factor formulas (tests/validation/test_reference_checks.py).
"""

from __future__ import annotations

import math

import numpy as np

from tests.reference import materials as mat

_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)


def view_opening(a, length, phi):
    """``F_O(a)``: view factor from the point at distance ``a`` from V on a wall to the opening."""
    d = np.sqrt(length * length + a * a - 2.0 * a * length * np.cos(phi))
    return 0.5 * (1.0 - (length * np.cos(phi) - a) / d)


def kernel(a, b, phi):
    """Point-to-point exchange density ``a b sin²Φ / (2 r³)`` between the two walls."""
    r2 = a * a + b * b - 2.0 * a * b * np.cos(phi)
    return a * b * np.sin(phi) ** 2 / (2.0 * r2 ** 1.5)


def _panels_about(a, length, phi, n_levels: int = 14):
    """Panel edges on ``[0, L]`` graded geometrically about ``b = a`` (scale ``a sin Φ``)."""
    width = np.maximum(a * np.sin(phi), 1e-9 * length)
    steps = width[..., None] * (2.0 ** np.arange(n_levels))[None, :] * 0.5
    left = np.clip(a[..., None] - steps, 0.0, length[..., None])
    right = np.clip(a[..., None] + steps, 0.0, length[..., None])
    edges = np.concatenate([np.zeros_like(a)[..., None], left, a[..., None], right,
                            np.broadcast_to(length, a.shape)[..., None]], axis=-1)
    return np.sort(edges, axis=-1)


def integrate_over_other_wall(a, length, phi, f):
    """``∫_0^L K(a, b) f(b) db`` for arrays ``a``, ``length``, ``phi`` (same shape)."""
    a, length, phi = np.broadcast_arrays(*[np.asarray(x, dtype=np.float64) for x in (a, length, phi)])
    edges = _panels_about(a, length, phi)
    lo, hi = edges[..., :-1, None], edges[..., 1:, None]
    b = 0.5 * (lo + hi) + 0.5 * (hi - lo) * _GL_X
    wb = 0.5 * (hi - lo) * _GL_W
    val = kernel(a[..., None, None], b, phi[..., None, None]) * f(b, length[..., None, None], phi[..., None, None])
    return np.sum(np.where(wb > 0.0, val * wb, 0.0), axis=(-1, -2))


def second_order_density(a, length, phi):
    """``g(a) = ∫_0^L K(a, b) F_O(b) db``: from a point of one wall, to the other, then out."""
    return integrate_over_other_wall(a, length, phi, lambda b, L, p: view_opening(b, L, p))


def lit_interval(theta_m, dx, dz):
    """``P_A`` and ``a_0`` of the left wall A for light travelling along ``(dx, ·, dz)``."""
    t = np.tan(theta_m)
    length = 1.0 / np.cos(theta_m)
    xv = t * dx / dz
    p_a = 0.5 * (np.clip(xv, -1.0, 1.0) + 1.0)
    # every ray reaches A when x_V >= 1: the ray from x' = 1 hits A at depth a_0 > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -t * 2.0 / (dz + t * dx)
        x_hit = 1.0 + s * dx
    a0 = np.where(xv >= 1.0, np.clip(-x_hit, 0.0, 1.0) * length, 0.0)
    return p_a, a0


def _mean_second_order(theta_m, a0, n_a):
    """``mean_{[a_0, L]} g`` per element (``a = a_0 + (L - a_0) u²``, graded toward ``a_0``)."""
    length = 1.0 / np.cos(theta_m)
    phi = math.pi - 2.0 * theta_m
    span = length - a0
    x, wx = np.polynomial.legendre.leggauss(n_a)
    u = 0.5 * (x + 1.0)
    a = a0[..., None] + span[..., None] * u ** 2
    wa = 0.5 * wx * 2.0 * u  # d(u²) = 2u du; mean = ∫ g da / span
    g = second_order_density(a, np.broadcast_to(length[..., None], a.shape),
                             np.broadcast_to(phi[..., None], a.shape))
    return np.sum(g * wa, axis=-1)


def groove_albedos(theta_m, dx, dz, n_a: int = 16):
    """Per groove: ``(e1, e2)`` with order-1 albedo ``kd e1`` and order-2 albedo ``kd² e2``."""
    theta_m, dx, dz = np.broadcast_arrays(*[np.asarray(x, dtype=np.float64) for x in (theta_m, dx, dz)])
    length = 1.0 / np.cos(theta_m)
    phi = math.pi - 2.0 * theta_m
    e1 = np.zeros(theta_m.shape)
    e2 = np.zeros(theta_m.shape)
    # g depends on (theta_m, a) only: the fully lit walls (a_0 = 0) share one mean per theta_m
    unique, inverse = np.unique(theta_m, return_inverse=True)
    full_mean = _mean_second_order(unique, np.zeros_like(unique), n_a)[inverse.reshape(theta_m.shape)]
    for sign in (1.0, -1.0):  # wall A, then wall B (mirror the light: d_x -> -d_x)
        p, a0 = lit_interval(theta_m, sign * dx, dz)
        span = length - a0
        d0 = np.sqrt(length ** 2 + a0 ** 2 - 2.0 * a0 * length * np.cos(phi))
        with np.errstate(divide="ignore", invalid="ignore"):
            mean1 = np.where(span > 0.0, 0.5 * (1.0 - (d0 - 2.0) / span), 0.0)
        mean2 = full_mean.copy()
        part = (a0 > 0.0) & (p > 0.0)
        if part.any():
            mean2[part] = _mean_second_order(theta_m[part], a0[part], n_a)
        e1 += p * mean1
        e2 += np.where(p > 0.0, p * mean2, 0.0)
    return e1, e2


def albedos(material: mat.Material, incident, n_gauss: int = 12, n_phi: int = 48, n_a: int = 16,
            chunk: int = 2048):
    """Order-1 and order-2 albedos of a Lambertian-facet material (``eta = 1``) at ``incident``."""
    if material.is_mirror or material.eta != 1.0:
        raise ValueError("lambertian_orders: Lambertian facets (eta = 1) only")
    i = np.asarray(incident, dtype=np.float64)
    m, w, theta, phi = mat.normal_quadrature(material, n_gauss, n_phi)
    keep = w > 0.0
    w, theta, phi = w[keep], theta[keep], phi[keep]
    dx = -(i[0] * np.cos(phi) + i[1] * np.sin(phi))
    dz = np.full_like(dx, -i[2])
    f1 = f2 = 0.0
    for s in range(0, theta.size, chunk):
        e1, e2 = groove_albedos(theta[s:s + chunk], dx[s:s + chunk], dz[s:s + chunk], n_a)
        f1 += float(w[s:s + chunk] @ e1)
        f2 += float(w[s:s + chunk] @ e2)
    return material.kd * f1, material.kd ** 2 * f2


def groove_monte_carlo(theta_m: float, dx: float, dz: float, n: int, seed: int = 0, k_max: int = 2):
    """Plain 2-D random walk in one Lambertian groove (unit albedo): exit fractions by order.

    Entry uniform on the opening along ``(dx, dz)``; at a wall the new in-plane direction
    makes the angle ``ϑ`` with the wall normal, ``sin ϑ`` uniform on ``(-1, 1)`` (the
    projection of a 3-D cosine-weighted direction). Returns ``[P(order 1), ..., P(order
    k_max)]``; multiply by ``kd^k`` for albedo ``kd``. A check of :func:`groove_albedos`.
    """
    rng = np.random.default_rng(seed)
    t = math.tan(theta_m)
    st, ct = math.sin(theta_m), math.cos(theta_m)
    x = rng.uniform(-1.0, 1.0, n)
    z = np.zeros(n)
    ddx = np.full(n, dx) / math.hypot(dx, dz)
    ddz = np.full(n, dz) / math.hypot(dx, dz)
    surface = np.zeros(n, dtype=np.int64)
    alive = np.ones(n, dtype=bool)
    out = np.zeros(k_max)
    for k in range(1, k_max + 2):
        with np.errstate(divide="ignore", invalid="ignore"):
            s_l = -(z + t * (1.0 + x)) / (ddz + t * ddx)
            s_r = -(z + t * (1.0 - x)) / (ddz - t * ddx)
            s_o = -z / ddz
        s_l = np.where((surface != 1) & (s_l > 0) & (ddz + t * ddx < 0), s_l, np.inf)
        s_r = np.where((surface != 2) & (s_r > 0) & (ddz - t * ddx < 0), s_r, np.inf)
        s_o = np.where((surface != 0) & (s_o > 0) & (ddz > 0), s_o, np.inf)
        best = np.minimum(np.minimum(s_l, s_r), s_o)
        hit = np.where(best == s_o, 0, np.where(best == s_l, 1, 2))
        exits = alive & (hit == 0)
        if k >= 2:
            out[k - 2] += exits.sum() / n
        alive &= hit != 0
        if k == k_max + 1:
            break
        x = x + best * ddx
        z = z + best * ddz
        surface = hit
        nx = np.where(hit == 1, st, -st)
        sin_v = rng.uniform(-1.0, 1.0, n)
        cos_v = np.sqrt(1.0 - sin_v * sin_v)
        # tangent (nz, -nx): new direction cos_v n + sin_v tangent
        ddx = cos_v * nx + sin_v * ct
        ddz = cos_v * ct - sin_v * nx
    return out
