"""The equal-area concentric sensor from its definition, in plain NumPy (physics.md sec. 6).

No code of ``vcavity.sensor.grid`` or ``vcavity.sensor.binning`` is used. Definitions:

- the square ``[-1, 1]²`` is cut into ``N x N`` equal squares; cell ``c = iy N + ix``
  covers ``u ∈ [-1 + 2 ix/N, -1 + 2 (ix + 1)/N]``, ``v`` alike;
- Shirley-Chiu: if ``|u| >= |v|`` the disk point has radius ``r = u`` (signed) and angle
  ``(π/4)(v/u)``, else radius ``v`` and angle ``π/2 - (π/4)(u/v)``;
- lift: ``z = 1 - r²``, ``(x, y) = (d_x, d_y) sqrt(2 - r²)``; ``dω = (π/2) du dv``.

:func:`direction_to_square` inverts it with ``arctan2`` on the disk point
``(x, y)/sqrt(1 + z)`` (a different route from the package's ``atan`` of a ratio), and
:func:`cells_of` bins.

:func:`cell_quadrature` is a per-cell rule in ``(u, v)``: the map has kinks only on the
diagonals ``|u| = |v|`` (wedge boundaries; it is analytic inside each wedge, including
across the axes), and for a symmetric grid these diagonals run corner to corner through
the cells with ``ix == iy`` or ``ix + iy == N - 1``. Such cells are split into two
triangles (four for the centre cell of an odd ``N``), each integrated in collapsed
(Duffy) coordinates ``(a, b) ∈ [0, 1]²``: ``p = A + a ((B - A) + b (C - B))``, Jacobian
``a |det(B - A, C - B)|``; every piece is then subdivided into ``n_sub x n_sub`` squares
in its own coordinates with ``n_gauss x n_gauss`` Gauss-Legendre points each. Measured
(tests/validation/test_reference_checks.py): ``Σ`` weights per cell equals ``2π/N²`` to
1e-15 relative, ``∫_c cos θ dω`` equals the closed form ``(π/2)∫∫(1 - max(u², v²))`` to
1e-15 relative and ``∫_c z^5 dω`` agrees between rules to 1e-14 relative, for every cell
(the integrands are polynomials in ``(u, v)`` resp. smooth in each piece).
"""

from __future__ import annotations

import math

import numpy as np

QUARTER_PI = 0.25 * math.pi


def square_to_direction(u, v) -> np.ndarray:
    """Concentric map + lift: square points -> unit directions (..., 3) with ``z >= 0``."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    u, v = np.broadcast_arrays(u, v)
    u_major = np.abs(u) >= np.abs(v)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(u_major, u, v)
        phi = np.where(u_major, QUARTER_PI * (v / u), 0.5 * math.pi - QUARTER_PI * (u / v))
    phi = np.where(r == 0.0, 0.0, phi)
    dx, dy = r * np.cos(phi), r * np.sin(phi)
    lift = np.sqrt(2.0 - r * r)
    return np.stack([dx * lift, dy * lift, 1.0 - r * r], axis=-1)


def direction_to_square(directions):
    """Inverse of :func:`square_to_direction` for upper-hemisphere directions: ``(u, v)``."""
    d = np.asarray(directions, dtype=np.float64)
    norm = np.sqrt(np.sum(d * d, axis=-1))
    norm = np.where(norm > 0.0, norm, 1.0)
    x, y, z = d[..., 0] / norm, d[..., 1] / norm, np.clip(d[..., 2] / norm, 0.0, 1.0)
    disk_x, disk_y = x / np.sqrt(1.0 + z), y / np.sqrt(1.0 + z)
    r = np.minimum(np.hypot(disk_x, disk_y), 1.0)
    phi = np.arctan2(disk_y, disk_x)  # (-π, π]
    q = QUARTER_PI
    u = np.empty_like(r)
    v = np.empty_like(r)
    right = np.abs(phi) <= q
    top = (phi > q) & (phi < 3 * q)
    bottom = (phi < -q) & (phi > -3 * q)
    left = ~(right | top | bottom)
    u[right], v[right] = r[right], r[right] * phi[right] / q
    u[top], v[top] = r[top] * (0.5 * math.pi - phi[top]) / q, r[top]
    u[bottom], v[bottom] = r[bottom] * (0.5 * math.pi + phi[bottom]) / q, -r[bottom]
    phi_left = np.where(phi[left] > 0, phi[left] - math.pi, phi[left] + math.pi)
    u[left], v[left] = -r[left], -r[left] * phi_left / q
    return u, v


def _bin(t, n):
    return np.clip(np.floor((t + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)


def cells_of(directions, n: int) -> np.ndarray:
    """Cell index ``iy N + ix`` of each direction (..., 3)."""
    u, v = direction_to_square(directions)
    return _bin(v, n) * n + _bin(u, n)


def cell_bounds(n: int):
    """``u0, u1, v0, v1`` arrays over cells ``c = iy N + ix``."""
    c = np.arange(n * n)
    ix, iy = c % n, c // n
    w = 2.0 / n
    return -1.0 + w * ix, -1.0 + w * (ix + 1), -1.0 + w * iy, -1.0 + w * (iy + 1)


def projected_solid_angle(n: int) -> np.ndarray:
    """``Ω⊥_c = (π/2) ∫∫_c (1 - max(u², v²)) du dv`` per cell, exactly (no quadrature
    error: see :func:`_pos_integral`). Independent of :func:`cell_quadrature`."""
    u0, u1, v0, v1 = cell_bounds(n)
    out = np.array([_pos_integral(u0[c], u1[c], v0[c], v1[c]) for c in range(n * n)])
    return 0.5 * math.pi * out


def _pos_integral(a0, a1, b0, b1, pieces: int = 64):
    """``∫_{a0}^{a1}∫_{b0}^{b1} (1 - max(u², v²)) dv du`` exactly: piecewise polynomial in u.

    For fixed ``u`` the inner integral is ``(1 - u²) len({|v| < |u|}) + ∫ (1 - v²)`` over
    the rest, a polynomial of degree <= 3 in ``u`` between the breakpoints
    ``{0, ±b0, ±b1}``; Simpson's rule (exact for cubics) on each piece.
    """
    def inner(u):
        au = abs(u)
        lo, hi = max(b0, -au), min(b1, au)
        flat = (1.0 - u * u) * max(0.0, hi - lo)
        prim = lambda t: t - t ** 3 / 3.0
        if hi > lo:
            rest = (prim(lo) - prim(b0)) + (prim(b1) - prim(hi))
        else:
            rest = prim(b1) - prim(b0)
        return flat + rest

    cuts = sorted({a0, a1, *[p for p in (0.0, b0, -b0, b1, -b1) if a0 < p < a1]})
    total = 0.0
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        mid = 0.5 * (lo + hi)
        total += (hi - lo) / 6.0 * (inner(lo) + 4.0 * inner(mid) + inner(hi))
    return total


def _pieces(n: int, c: int):
    """Pieces of cell ``c``: list of ("rect", u0, u1, v0, v1) or ("tri", A, B, C)."""
    ix, iy = c % n, c // n
    u0, u1, v0, v1 = (-1.0 + 2.0 * ix / n, -1.0 + 2.0 * (ix + 1) / n,
                      -1.0 + 2.0 * iy / n, -1.0 + 2.0 * (iy + 1) / n)
    on_main = ix == iy  # the line v = u runs from (u0, v0) to (u1, v1)
    on_anti = ix + iy == n - 1  # the line v = -u runs from (u0, v1) to (u1, v0)
    p00, p10, p01, p11 = (u0, v0), (u1, v0), (u0, v1), (u1, v1)
    if on_main and on_anti:  # centre cell of odd N: four triangles with apex at the origin
        o = (0.0, 0.0)
        return [("tri", o, p10, p11), ("tri", o, p11, p01), ("tri", o, p01, p00), ("tri", o, p00, p10)]
    if on_main:
        return [("tri", p00, p10, p11), ("tri", p00, p01, p11)]
    if on_anti:
        return [("tri", p10, p00, p01), ("tri", p10, p11, p01)]
    return [("rect", u0, u1, v0, v1)]


def cell_quadrature(n: int, n_gauss: int = 6, n_sub: int = 1, cells=None):
    """Per-cell quadrature for ``∫_c g(o) dω_o``.

    Returns ``directions`` (P, 3), ``weights`` (P,) in sr (``dω = (π/2) du dv``) and
    ``cell`` (P,) sorted ascending, so that ``np.bincount(cell, weights * g(directions))``
    is the per-cell integral. See the module docstring for the splitting of diagonal cells.
    """
    x, wx = np.polynomial.legendre.leggauss(n_gauss)
    # composite rule on [0, 1]: n_sub panels x n_gauss points
    edges = np.arange(n_sub + 1) / n_sub
    t = ((edges[:-1, None] + edges[1:, None]) * 0.5 + 0.5 * (edges[1:, None] - edges[:-1, None]) * x).ravel()
    wt = (0.5 * (edges[1:, None] - edges[:-1, None]) * wx).ravel()
    aa, bb = np.meshgrid(t, t, indexing="ij")
    ww = np.outer(wt, wt)
    aa, bb, ww = aa.ravel(), bb.ravel(), ww.ravel()
    us, vs, ws, cs = [], [], [], []
    for c in (range(n * n) if cells is None else cells):
        for piece in _pieces(n, int(c)):
            if piece[0] == "rect":
                _, u0, u1, v0, v1 = piece
                us.append(u0 + (u1 - u0) * aa)
                vs.append(v0 + (v1 - v0) * bb)
                ws.append(ww * (u1 - u0) * (v1 - v0))
            else:
                _, A, B, C = piece
                A, B, C = np.array(A), np.array(B), np.array(C)
                e1, e2 = B - A, C - B
                det = abs(e1[0] * e2[1] - e1[1] * e2[0])
                us.append(A[0] + aa * (e1[0] + bb * e2[0]))
                vs.append(A[1] + aa * (e1[1] + bb * e2[1]))
                ws.append(ww * aa * det)
            cs.append(np.full(aa.size, int(c)))
    u, v, w, cell = np.concatenate(us), np.concatenate(vs), np.concatenate(ws), np.concatenate(cs)
    return square_to_direction(u, v), 0.5 * math.pi * w, cell
