"""Deterministic paths in one V-groove, and the bounce orders ``f_k`` per cell, in NumPy.

For mirror facets and ``kd = 0`` dielectric facets the path inside a groove is
deterministic given the groove normal ``m`` and the entry point ``x'`` on the opening
(physics.md sec. 5); its probability weight is the product of the Fresnel factors
``F(c)`` at the hits (1 for mirrors; the rest is absorbed by a ``kd = 0`` body). So

    P_k[c] = ∫ D(m)(m.n) dω_m ∫_{-1}^{1} dx'/2 [k bounces] (weight) [exit in c]

is the exact probability that a simulated path is an order-``k`` exit in cell ``c``.

Geometry (groove frame; our own derivation, independent of vcavity.kernels.groove).
The cross-section is the triangle with vertex ``V = (0, -T)``, ``T = tan θ_m``, rims
``(±1, 0)``; the walls have length ``L = sec θ_m``. Seen from ``V`` the right wall lies at
angle ``θ_m`` and the left wall at ``π - θ_m``: the groove is the wedge
``[θ_m, θ_m + 2ψ]``, ``2ψ = π - 2θ_m``. Light travels along ``d = -i`` (in groove
coordinates); motion along the groove axis ``y'`` never changes which wall is hit.

*Unfolding* (:func:`unfold`, the tracer used for the tables). Reflecting the wedge
about its walls again and again tiles a fan of wedges ``W_j = [a_j, a_j + 2ψ]``,
``a_j = θ_m + 2jψ``, whose rim points ``C_j = V + L (cos a_j, sin a_j)`` are the corners
of a regular (convex) polygon. A reflected path is a straight line in the fan, so

- the bounces are the boundary rays ``a_j`` the line crosses at a radius ``r < L``
  (``r = ((E - V) x d)/(u_a x d)`` for the unit vector ``u_a`` of the ray, ``x`` the 2-D
  cross product), walked one wedge at a time from the entry point ``E = (x', 0)`` in the
  sense of rotation ``sign((E - V) x d)``; the path leaves through the chord of the first
  wedge whose far boundary it does not cross within ``L``;
- the cosine at each hit is ``|u_a x d|`` (unfolding preserves angles; ``d`` is the 3-D
  unit direction's in-plane part, so this is the 3-D cosine to the wall normal);
- leaving from wedge ``W_j``, the real direction is ``L_j^{-1} d``, with ``L_j`` the
  rotation by ``2jψ`` (``j`` even) or the reflection about the line at angle
  ``θ_m + (j + 1)ψ`` (``j`` odd); the ``y'`` component is unchanged.

For a fixed ``m`` the outcome (number of bounces, exit direction, weight) is constant in
``x'`` between the values where the line passes through ``V`` or a corner ``C_j``:
``x' = C_x - C_z d_x/d_z``. :func:`groove_orders` integrates ``x'`` exactly on these
pieces and ``m`` with :func:`tests.reference.materials.normal_quadrature` (binning makes the
``m`` integrand discontinuous: its error is measured by refinement, see
tests/validation/test_reference_checks.py and :data:`ACCURACY`).

*Explicit stepping* (:func:`trace_steps`): the textbook alternative, intersecting the
ray with the two wall lines and the opening and reflecting ``d ← d - 2 (d.n) n``; used
only to check :func:`unfold` (they agree on bounce counts, directions and weights).
"""

from __future__ import annotations

import math

import numpy as np

from tests.reference import materials as mat
from tests.reference import sensor as sen

#: Measured quadrature error of :func:`groove_orders` (N = 9; against 512 x 1024 patches,
#: and for f1 against the independent single-bounce reference; Beckmann 0.8 and GGX 0.5
#: mirrors, Beckmann 0.8 and GGX 0.6 dielectrics): relative L1 of the cell table and
#: relative albedo error per order, for the n_t x n_phi grids used by the tests.
ACCURACY = {
    (128, 256): {"f1_l1": 4e-4, "f2_l1": 1.3e-3, "f3_l1": 2.2e-2, "f1_albedo": 8e-6, "f2_albedo": 3e-5,
                 "f3_albedo": 2e-3},
    (256, 512): {"f1_l1": 1.5e-4, "f2_l1": 3.5e-4, "f3_l1": 5e-3, "f1_albedo": 1e-6, "f2_albedo": 8e-6,
                 "f3_albedo": 2e-4},
}
#: chi-square inflation ``paths Σ (ΔP)²/P`` over the cells a test keeps alone, at 2e6
#: paths: <= 0.6 (f2) and <= 0.4 (f3) on 256 x 512 for mirrors; <= 0.06 on 192 x 384 for
#: the dielectrics (whose f2, f3 are small).


def _cross(ax, az, bx, bz):
    return ax * bz - az * bx


def unfold(theta_m, x0, dx, dy, dz, k_max, reflectance=None):
    """Trace rays entering the groove at ``x0`` along ``(dx, dy, dz)`` (unit, ``dz < 0``).

    All arguments broadcast to one shape ``(R,)``. ``reflectance(cos) -> F`` weights
    every hit (``None``: mirror, weight 1). Returns ``k`` (bounces; ``k_max + 1`` means
    "more than ``k_max``"), the exit direction ``(ex, ey, ez)`` in the groove frame
    (undefined where ``k > k_max``) and the weight.
    """
    theta_m, x0, dx, dy, dz = np.broadcast_arrays(*[np.asarray(a, dtype=np.float64)
                                                   for a in (theta_m, x0, dx, dy, dz)])
    t = np.tan(theta_m)
    length = 1.0 / np.cos(theta_m)
    two_psi = math.pi - 2.0 * theta_m
    wx, wz = x0, t  # E - V = (x0, 0) - (0, -T)
    num = _cross(wx, wz, dx, dz)
    sense = np.where(num > 0.0, 1, -1)
    j = np.zeros(theta_m.shape, dtype=np.int64)
    k = np.zeros(theta_m.shape, dtype=np.int64)
    weight = np.ones(theta_m.shape)
    active = np.ones(theta_m.shape, dtype=bool)
    for _ in range(k_max + 1):
        a = theta_m + two_psi * np.where(sense > 0, j + 1, j)  # the boundary ahead
        ua_x, ua_z = np.cos(a), np.sin(a)
        den = _cross(ua_x, ua_z, dx, dz)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = num / den
        crossed = active & (r > 0.0) & (r < length)
        if reflectance is not None:
            c = np.abs(den)
            weight = np.where(crossed, weight * reflectance(np.where(crossed, c, 1.0)), weight)
        k = k + crossed
        j = j + np.where(crossed, sense, 0)
        active = crossed
        if not active.any():
            break
    # real exit direction: L_j^{-1} d
    odd = (j % 2) != 0
    rot = -two_psi * j  # rotation by -2 j psi (j even)
    ex_even = np.cos(rot) * dx - np.sin(rot) * dz
    ez_even = np.sin(rot) * dx + np.cos(rot) * dz
    gamma = theta_m + (j + 1) * (0.5 * two_psi)
    c2, s2 = np.cos(2.0 * gamma), np.sin(2.0 * gamma)
    ex_odd = c2 * dx + s2 * dz
    ez_odd = s2 * dx - c2 * dz
    ex = np.where(odd, ex_odd, ex_even)
    ez = np.where(odd, ez_odd, ez_even)
    return k, ex, dy + 0.0 * ex, ez, weight, j


def exit_world(theta_m, phi_m, j, incident):
    """World exit direction of a path that leaves from wedge ``j`` of groove ``(θ_m, φ_m)``.

    For a fixed wedge sequence the exit direction is an analytic function of ``m``:
    ``o = R(φ_m) L_j(θ_m)^{-1} d(φ_m)`` (see the module docstring), which lets
    :func:`groove_orders` sub-sample a quadrature patch of normals without retracing.
    """
    theta_m, phi_m, j = np.broadcast_arrays(np.asarray(theta_m, dtype=np.float64),
                                            np.asarray(phi_m, dtype=np.float64), np.asarray(j))
    dx, dy, dz = groove_frame_direction(incident, phi_m)
    two_psi = math.pi - 2.0 * theta_m
    odd = (j % 2) != 0
    rot = -two_psi * j
    gamma = theta_m + (j + 1) * (0.5 * two_psi)
    c2, s2 = np.cos(2.0 * gamma), np.sin(2.0 * gamma)
    ex = np.where(odd, c2 * dx + s2 * dz, np.cos(rot) * dx - np.sin(rot) * dz)
    ez = np.where(odd, s2 * dx - c2 * dz, np.sin(rot) * dx + np.cos(rot) * dz)
    c, sn = np.cos(phi_m), np.sin(phi_m)
    return np.stack([ex * c - dy * sn, ex * sn + dy * c, ez], axis=-1)


def trace_steps(theta_m, x0, dx, dy, dz, k_max, reflectance=None):
    """The same as :func:`unfold` by explicit line intersections and reflections (a check)."""
    theta_m, x, dx, dy, dz = np.broadcast_arrays(*[np.asarray(a, dtype=np.float64).copy()
                                                  for a in (theta_m, x0, dx, dy, dz)])
    x, dx, dz = x.copy(), dx.copy(), dz.copy()
    t = np.tan(theta_m)
    st, ct = np.sin(theta_m), np.cos(theta_m)
    z = np.zeros_like(x)
    surface = np.zeros(x.shape, dtype=np.int64)  # 0 opening, 1 left wall, 2 right wall
    k = np.zeros(x.shape, dtype=np.int64)
    weight = np.ones(x.shape)
    inside = np.ones(x.shape, dtype=bool)
    for _ in range(k_max + 1):
        with np.errstate(divide="ignore", invalid="ignore"):
            # left wall z = -T (1 + x): s = -(z + T (1 + x)) / (dz + T dx)
            s_left = -(z + t * (1.0 + x)) / (dz + t * dx)
            s_right = -(z + t * (1.0 - x)) / (dz - t * dx)
            s_open = np.where(dz > 0.0, -z / dz, np.inf)
        s_left = np.where((surface != 1) & (s_left > 0.0) & ((dz + t * dx) < 0.0), s_left, np.inf)
        s_right = np.where((surface != 2) & (s_right > 0.0) & ((dz - t * dx) < 0.0), s_right, np.inf)
        s_open = np.where((surface != 0) & (s_open > 0.0), s_open, np.inf)
        best = np.minimum(np.minimum(s_left, s_right), s_open)
        hit = np.where(best == s_open, 0, np.where(best == s_left, 1, 2))
        hit = np.where(inside, hit, 0)
        x = np.where(inside, x + best * dx, x)
        z = np.where(inside, z + best * dz, z)
        wall = inside & (hit != 0)
        nx = np.where(hit == 1, st, -st)
        c = -(dx * nx + dz * ct)
        if reflectance is not None:
            weight = np.where(wall, weight * reflectance(np.where(wall, c, 1.0)), weight)
        dx = np.where(wall, dx + 2.0 * c * nx, dx)
        dz = np.where(wall, dz + 2.0 * c * ct, dz)
        k = k + wall
        surface = np.where(inside, hit, surface)
        inside = wall
        if not inside.any():
            break
    k = np.where(inside, k_max + 1, k)
    return k, dx, dy, dz, weight


def breakpoints(theta_m, dx, dz, k_max):
    """Entry points ``x'`` (M, n) where the outcome can change: lines through ``V`` or ``C_j``."""
    theta_m = np.asarray(theta_m, dtype=np.float64)[:, None]
    dx = np.asarray(dx, dtype=np.float64)[:, None]
    dz = np.asarray(dz, dtype=np.float64)[:, None]
    t = np.tan(theta_m)
    length = 1.0 / np.cos(theta_m)
    two_psi = math.pi - 2.0 * theta_m
    j = np.arange(-(k_max + 3), k_max + 5)[None, :]
    a = theta_m + two_psi * j
    cx, cz = length * np.cos(a), -t + length * np.sin(a)
    xs = cx - cz * dx / dz
    xv = t * dx / dz
    return np.concatenate([xs, xv], axis=1)


def groove_frame_direction(incident, phi_m):
    """``d = -i`` in the groove frame of azimuth ``phi_m``: ``(d.x', d.y', d.z)``."""
    i = np.asarray(incident, dtype=np.float64)
    c, s = np.cos(phi_m), np.sin(phi_m)
    return -(i[0] * c + i[1] * s), -(-i[0] * s + i[1] * c), -i[2] + 0.0 * c


def normal_grid(material: mat.Material, n_t: int, n_phi: int):
    """Midpoint grid over normals for the discontinuous integrands of this module.

    ``tan θ_m = s t/(1 - t)`` with ``s = tan`` of the distribution's angular scale,
    ``t ∈ (0, 1)`` and ``φ_m ∈ (0, 2π)`` each cut into equal patches (midpoints), weights
    ``D(m) cos θ sin θ (dθ/dt) Δt Δφ``, ``dθ/dt = s/((1 - t)² (1 + tan²θ))``. Returns
    ``theta, phi, w, dt, dphi, t`` (per node; ``dt``, ``dphi`` the patch sizes). The GGX
    tail ``∝ tan^-3`` becomes ``∝ (1 - t)`` in ``t``: smooth.
    """
    s = math.tan(mat.angular_scale(material))
    dt, dphi = 1.0 / n_t, 2.0 * math.pi / n_phi
    t = (np.arange(n_t) + 0.5) * dt
    rho = s * t / (1.0 - t)
    theta = np.arctan(rho)
    dtheta_dt = s / ((1.0 - t) ** 2 * (1.0 + rho * rho))
    phi = (np.arange(n_phi) + 0.5) * dphi
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    m = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1)
    w = mat.ndf(material, m) * np.cos(tt) * np.sin(tt) * (dtheta_dt * dt)[:, None] * dphi
    return tt.ravel(), pp.ravel(), w.ravel(), dt, dphi, np.repeat(t, n_phi)


def _theta_of_t(t, s):
    return np.arctan(s * t / (1.0 - t))


def groove_orders(material: mat.Material, incident, n: int, k_max: int = 3, n_t: int = 128,
                  n_phi: int = 256, n_split: int = 8, chunk: int = 4096):
    """Per-cell exit probabilities of orders ``1..k_max`` and the rest.

    Normals on :func:`normal_grid`; ``x'`` integrated exactly over the pieces between
    :func:`breakpoints`; each piece traced by :func:`unfold`. A piece's exit cell is a
    discontinuous function of ``m``: where the exit directions of the patch's four corners
    and centre (same wedge sequence, :func:`exit_world`) do not all fall in one cell, the
    piece's weight is spread over ``n_split x n_split`` sub-points of the patch (a regular
    sub-grid shifted by a per-patch offset drawn once from a fixed seed). Returns
    ``(P, rest)``: ``P[k - 1, c]`` the probability of an order-``k`` exit in cell ``c``;
    ``rest`` the weight of paths with more than ``k_max`` bounces not yet absorbed after
    ``k_max + 1`` hits (mirrors: the probability of exiting after more than ``k_max``).
    """
    if material.has_body:
        raise ValueError("groove_orders: deterministic paths need mirror or kd = 0 facets")
    reflectance = None if material.is_mirror else (lambda c: mat.fresnel_reflectance(c, material.eta))
    theta, phi, wm, dt, dphi, tnode = normal_grid(material, n_t, n_phi)
    s_scale = math.tan(mat.angular_scale(material))
    keep = wm > 0.0
    theta, phi, wm, tnode = theta[keep], phi[keep], wm[keep], tnode[keep]
    out = np.zeros((k_max, n * n))
    rest = 0.0
    corners = np.array([[-0.5, -0.5], [-0.5, 0.5], [0.5, -0.5], [0.5, 0.5]])
    sub = np.arange(n_split) / n_split
    sub_t, sub_p = [a.ravel() for a in np.meshgrid(sub, sub, indexing="ij")]
    # each mixed patch gets its own shift of the n_split x n_split sub-grid (Cranley-Patterson
    # rotation, fixed seed: deterministic): a cell boundary aligned with the grid (e.g. the
    # pole cell at normal incidence, a circle theta_m = const) would otherwise be misplaced
    # coherently by up to half a sub-row along its whole length
    rng = np.random.default_rng(20240611)
    for s in range(0, theta.size, chunk):
        th, ph, w, tn = theta[s:s + chunk], phi[s:s + chunk], wm[s:s + chunk], tnode[s:s + chunk]
        dx, dy, dz = groove_frame_direction(incident, ph)
        bp = np.clip(breakpoints(th, dx, dz, k_max), -1.0, 1.0)
        edges = np.sort(np.concatenate([np.full((th.size, 1), -1.0), bp, np.ones((th.size, 1))], axis=1), axis=1)
        lo, hi = edges[:, :-1], edges[:, 1:]
        length = hi - lo
        use = length > 0.0
        row = np.broadcast_to(np.arange(th.size)[:, None], use.shape)[use]
        mid = 0.5 * (lo + hi)[use]
        piece_w = w[row] * 0.5 * length[use]
        k, ex, ey, ez, weight, j = unfold(th[row], mid, dx[row], dy[row], dz[row], k_max, reflectance)
        done = k <= k_max
        rest += float(np.sum(piece_w[~done] * weight[~done]))
        row, k, j, pw = row[done], k[done], j[done], (piece_w * weight)[done]
        c, sn = np.cos(ph[row]), np.sin(ph[row])
        centre = np.stack([ex[done] * c - ey[done] * sn, ex[done] * sn + ey[done] * c, ez[done]], axis=-1)
        cell = sen.cells_of(centre, n)
        mixed = np.zeros(row.size, dtype=bool)
        for ct, cp in corners:
            t_c = np.clip(tn[row] + ct * dt, 1e-12, 1.0 - 1e-12)
            o_c = exit_world(_theta_of_t(t_c, s_scale), ph[row] + cp * dphi, j, incident)
            mixed |= (o_c[:, 2] <= 0.0) | (sen.cells_of(o_c, n) != cell)
        clean = ~mixed
        np.add.at(out, (k[clean] - 1, cell[clean]), pw[clean])
        if mixed.any():
            r_m = row[mixed]
            shift = rng.random((r_m.size, 2)) / n_split
            frac_t = (sub_t[None, :] + shift[:, :1]) % 1.0 - 0.5
            frac_p = (sub_p[None, :] + shift[:, 1:]) % 1.0 - 0.5
            t_s = np.clip(tn[r_m][:, None] + frac_t * dt, 1e-12, 1.0 - 1e-12)
            p_s = ph[r_m][:, None] + frac_p * dphi
            o_s = exit_world(_theta_of_t(t_s, s_scale), p_s, j[mixed][:, None], incident)
            # a sub-point whose wedge sequence would not exit (o_z <= 0) is dropped and its
            # share given to the others; a patch without any valid sub-point keeps its
            # centre's cell (the piece's weight is never lost)
            ok = o_s[..., 2] > 0.0
            none = ~ok.any(axis=1)
            ok[none, 0] = True
            o_s[none, 0] = centre[mixed][none]
            frac = ok / ok.sum(axis=1, keepdims=True)
            cells_s = sen.cells_of(o_s.reshape(-1, 3), n).reshape(o_s.shape[:-1])
            kk = np.broadcast_to(k[mixed][:, None], cells_s.shape)
            np.add.at(out, (kk.ravel() - 1, cells_s.ravel()), (frac * pw[mixed][:, None]).ravel())
    return out, rest


def order_albedos(material: mat.Material, incident, k_max: int, n_t: int = 256, n_phi: int = 256):
    """Albedo of each order ``1..k_max`` (no sensor) and the weight left after ``k_max``."""
    P, rest = groove_orders(material, incident, 1, k_max, n_t, n_phi, n_split=1)
    return P[:, 0], rest
