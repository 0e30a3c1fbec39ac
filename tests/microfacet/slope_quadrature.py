"""Deterministic quadratures over microfacet slopes for the conformance suite (not a test module).

Plain NumPy/SciPy, written from the definitions (physics.md sec. 1-3; H = Heitz 2014): a
normal ``m = normalize(-s_x, -s_y, 1)`` of slope ``s`` has ``dω_m = m_z^3 d²s`` (H app. A), so
the slope density ``P(s) = D(m) m_z^4`` integrates to 1 over the plane exactly when
``∫ D(m)(m.n) dω_m = 1``. The only package code evaluated is the distribution's own ``D``
(through the registry's vectorised :func:`vcavity.microfacet.registry.evaluate`): never a
sampler, ``Lambda`` or the masking code of the package. Nothing here knows a distribution by
name: the scales the rules are placed on are read off ``D`` itself (:func:`Lobe`), so a new
distribution is integrated with no edit.

- :meth:`Lobe.polar` integrates ``P`` or ``P (o_z - o.s)`` over the plane in stretched polar
  coordinates ``s = (w_x ρ cos ψ, w_y ρ sin ψ)``, ``ρ = e^y`` (power-law tails become
  exponential in ``y``): Gauss-Legendre in ``y``, midpoints (exact for trigonometric
  polynomials) in ``ψ``;
- :meth:`Lobe.aligned` integrates the Smith and V-cavity masking integrands, whose kinks
  lie on lines ``o.s = const``, in coordinates along and across the azimuth of ``o``, split
  at the kinks, each piece mapped by ``c + σ sinh(y)`` (algebraic tails become
  exponential);
- :meth:`Lobe.bin_probabilities` integrates ``P`` or ``P (v_z - v.s)+`` over the cells of a
  grid in stretched polar coordinates (the chi-square tests' bins), the positive part
  exactly (its zero set, a line, meets each circle ``ρ = const`` at two angles in closed
  form).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy import special

from vcavity.microfacet import registry


@functools.lru_cache(maxsize=None)
def _leggauss(n):
    return special.roots_legendre(n)  # O(n) (numpy's leggauss is an O(n^3) eigensolve)


def gauss_legendre(a, b, n):
    """Nodes and weights of the ``n``-point Gauss-Legendre rule on ``[a, b]`` (arrays of the same shape as a, b)."""
    x, w = _leggauss(n)
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    half = 0.5 * (b - a)
    return (a + half)[..., None] + half[..., None] * x, half[..., None] * w


def graded(y_lo, y_hi, per_panel=8):
    """Composite Gauss-Legendre on ``[y_lo, y_hi]``: panels 0.5 wide for ``|y| <= 4`` (the core
    of a lobe mapped by ``σ sinh(y)``), 2 wide beyond (its tails, exponential in ``y``),
    ``per_panel`` nodes each. Returns 1-D nodes and weights."""
    edges = graded_edges(y_lo, y_hi)
    y, w = gauss_legendre(edges[:-1], edges[1:], per_panel)
    return y.ravel(), w.ravel()


def graded_edges(y_lo, y_hi, extra=()):
    """The panel edges of :func:`graded` (plus the points ``extra`` inside the range)."""
    core = np.arange(-4.0, 4.0 + 0.25, 0.5)
    far = max(abs(y_lo), abs(y_hi))
    outer = np.arange(6.0, far + 2.0, 2.0)
    edges = np.concatenate([-outer[::-1], core, outer, [y_lo, y_hi], list(extra)])
    return np.unique(np.clip(edges, y_lo, y_hi))


def direction(theta, phi):
    """Unit vector of polar angle ``theta`` and azimuth ``phi`` (radians)."""
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


# the slope radii probed for the lobe's scales and tails: P is read on these along 8 azimuths
_PROBE_RHO = np.logspace(-150.0, 150.0, 3001)
_PROBE_PSI = np.arange(8) * (math.pi / 4.0)
#: Relative level below which the mass per unit of ln(rho) is left out (the tails' share of
#: an integral is then ~1e-16 and below: far below every tolerance here).
TAIL_LEVEL = 1e-17


class Lobe:
    """The slope density of one distribution and parameter array, and rules fitted to it.

    Parameters
    ----------
    kind : int
        The distribution's dispatch index.
    params : ndarray
        Its parameter array.

    Attributes
    ----------
    wx, wy : float
        Half-widths of the slope density along x and y: where ``P`` falls to half of ``P(0)``
        (read off ``D``; they only place the nodes, so a wrong value costs accuracy, which the
        refinement checks of the tests see, never a false pass).
    """

    def __init__(self, kind: int, params: np.ndarray):
        self.kind = int(kind)
        self.params = np.ascontiguousarray(params, dtype=np.float64)
        self.evaluations = 0
        rho = _PROBE_RHO
        rows = []
        for psi in _PROBE_PSI:
            rows.append(self.density(rho * math.cos(psi), rho * math.sin(psi)))
        self._probe = np.array(rows)  # (azimuth, rho)
        self.wx = self._half_width(self._probe[0])
        self.wy = self._half_width(self._probe[2])

    @staticmethod
    def _half_width(p):
        if not p[0] > 0.0:
            return 1.0
        below = np.flatnonzero(p < 0.5 * p[0])
        return float(_PROBE_RHO[below[0]]) if below.size else 1.0

    def density(self, sx, sy):
        """``P(s) = D(m) m_z^4`` at the slopes ``(sx, sy)`` (arrays of one shape), ``m = normalize(-s, 1)``."""
        sx = np.asarray(sx, dtype=np.float64)
        sy = np.asarray(sy, dtype=np.float64)
        r = np.hypot(sx, sy)
        mz = 1.0 / np.hypot(1.0, r)
        m = np.stack([-sx * mz, -sy * mz, mz], axis=-1).reshape(-1, 3)
        d = registry.evaluate("D", self.kind, m, self.params).reshape(sx.shape)
        self.evaluations += sx.size
        with np.errstate(under="ignore"):
            return d * mz**4

    def tail_extent(self, power: float) -> float:
        """``ln(R / min(wx, wy))`` with ``R`` the slope radius beyond which the mass per unit
        of ``ln ρ`` of ``P ρ^power`` (that is, ``P ρ^(2 + power)``) stays below
        :data:`TAIL_LEVEL` times its peak, along every probed azimuth; at least 5."""
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            g = self._probe * _PROBE_RHO ** (2.0 + power)
        g = np.where(np.isfinite(g), g, 0.0)
        top = g.max()
        above = np.flatnonzero((g > TAIL_LEVEL * top).any(axis=0))
        radius = _PROBE_RHO[above[-1]] if above.size else 1.0
        return max(5.0, math.log(radius / min(self.wx, self.wy)) + 1.0)

    # ------------------------------------------------------------------ whole-plane integrals

    def polar(self, o=None, n_y=700, n_psi=64):
        """``∫ P d²s`` (``o`` None: the normalisation, 1 for a normalised D) or the signed
        projected area ``∫ P (o_z - o.s) d²s`` (``o.n`` for a normalised D, W eq. 3), in
        stretched polar coordinates with ``ρ = e^y`` from ``e^-25`` to the tail extent."""
        # the signed term's rho cos(psi) part integrates to 0 over psi: the tail is P's own
        y, wy_ = gauss_legendre(-25.0, self.tail_extent(0.0) + 2.0, n_y)
        rho = np.exp(y)
        psi = (np.arange(n_psi) + 0.5) * (2.0 * math.pi / n_psi)
        rr, pp = np.meshgrid(rho, psi, indexing="ij")
        sx, sy = self.wx * rr * np.cos(pp), self.wy * rr * np.sin(pp)
        f = self.density(sx, sy)
        if o is not None:
            f = f * (o[2] - o[0] * sx - o[1] * sy)
        return float(np.sum(f.sum(axis=1) * (2.0 * math.pi / n_psi) * self.wx * self.wy * rho * rho * wy_))

    def aligned(self, o, masking: str, per_panel: int = 8) -> float:
        """A masking integral over the slopes, in coordinates along and across ``o``'s azimuth.

        ``masking = "smith"``: ``∫ P (o_z - o.s)+ d²s = ∫ D(m) <o, m>+ dω_m``, which is
        ``o_z (1 + Lambda(o))`` by Smith's definition (H eq. 26-28: the Smith weak furnace).
        ``masking = "vcavity"``: ``∫ P min((o_z - o.s)+, 2 o_z) d²s / o_z``
        ``= ∫ G1_V(o, m) D(m) <o, m>+ dω_m / o_z`` with ``G1_V = min(1, 2 m_z o_z / (o.m))``
        (H eq. 49), which is ``∫ G1_V(o, h) D(h) / (4 |o.n|) dω_i``, the weak white furnace
        (H eq. 36, with ``dω_i = 4 |o.h| dω_h``): 1 for a normalised D.

        In stretched slopes ``t = (s_x / w_x, s_y / w_y)`` the lobe is round and
        ``o.s = κ t_par`` with ``κ = |(o_x w_x, o_y w_y)|`` and ``t_par`` along that vector: the
        integrands kink at ``t_par = k`` and (V-cavity) ``-k``, ``k = o_z / κ``, and vanish
        beyond ``k``. The pieces ``[-k, k]`` and ``(-inf, -k]`` of ``t_par`` and the ``t_perp``
        axis are mapped by ``c + sinh(y)`` (the lobe's core resolved, algebraic tails made
        exponential) and integrated by :func:`graded` rules. ``o`` must not be the normal.
        """
        ex, ey = o[0] * self.wx, o[1] * self.wy
        kappa = math.hypot(ex, ey)
        ex, ey = ex / kappa, ey / kappa
        k = o[2] / kappa
        y_max = self.tail_extent(1.0 if masking == "smith" else 0.0) + math.log(2.0)  # sinh(y) ~ e^y / 2
        y, wy_ = graded(-y_max, y_max, per_panel)
        t_perp, w_perp = np.sinh(y), wy_ * np.cosh(y)
        y_mid = math.asinh(k)
        ym, wm = graded(-y_mid, y_mid, per_panel)
        yt, wt = graded(0.0, y_max, per_panel)
        pieces = [(np.sinh(ym), wm * np.cosh(ym)), (-k - np.sinh(yt), wt * np.cosh(yt))]
        total = 0.0
        for t_par, w_par in pieces:
            tp, tq = np.meshgrid(t_par, t_perp, indexing="ij")
            sx = self.wx * (tp * ex - tq * ey)
            sy = self.wy * (tp * ey + tq * ex)
            p = self.density(sx, sy)
            lit = np.maximum(o[2] - kappa * tp, 0.0)  # o_z - o.s
            if masking == "smith":
                f = p * lit
            elif masking == "vcavity":
                f = p * np.minimum(lit, 2.0 * o[2]) / o[2]
            else:
                raise ValueError(masking)
            total += float(w_par @ f @ w_perp)
        return total * self.wx * self.wy

    # ------------------------------------------------------------------ cells of a chi-square test

    def stretched(self, m):
        """Stretched polar coordinates ``(ρ, ψ)`` of unit normals ``m`` (N, 3), ``m_z > 0``:
        the slope ``s = -m_xy / m_z`` is ``(w_x ρ cos ψ, w_y ρ sin ψ)``, ``ψ`` in ``[-π, π]``."""
        sx, sy = -m[:, 0] / m[:, 2], -m[:, 1] / m[:, 2]
        u, v = sx / self.wx, sy / self.wy
        return np.hypot(u, v), np.arctan2(v, u)

    def bin_probabilities(self, rho_edges, psi_edges, v=None, n_rho=32, n_psi=16):
        """Integrals of ``P`` (``v`` None) or ``P (v_z - v.s)+`` (the density of the normals
        visible from ``v``, up to its normalisation) over each cell ``[ρ_i, ρ_i+1] x [ψ_j, ψ_j+1]``.

        ``rho_edges`` start at 0 and end at ``inf``: the last ring is integrated with
        ``ρ = ρ_last e^y`` to the tail extent, on :func:`graded_edges` panels. The positive part is integrated exactly: at each
        ``ρ`` node, ``(v_z - ρ k cos(ψ - ψ0))+`` is positive on one arc of the circle, whose ends
        are in closed form, and each cell's part of the arc gets its own Gauss-Legendre nodes.
        Returns an array (len(rho_edges) - 1, len(psi_edges) - 1).
        """
        rho_edges = np.asarray(rho_edges, dtype=np.float64)
        psi_edges = np.asarray(psi_edges, dtype=np.float64)
        n_r = rho_edges.size - 1
        out = np.empty((n_r, psi_edges.size - 1))
        if v is not None:
            kx, ky = v[0] * self.wx, v[1] * self.wy
            kk, psi0 = math.hypot(kx, ky), math.atan2(ky, kx)
        tail = self.tail_extent(1.0 if v is not None else 0.0) - math.log(max(rho_edges[-2], 1e-300))
        # where the arc of the positive part starts to shrink (v_z > 0) or to exist (v_z < 0):
        # the integrand behaves like (rho - rho_c)^(3/2) there, so a ring is split at rho_c
        # and its outer piece mapped by rho = rho_c + (hi - rho_c) u^2
        rho_c = abs(v[2]) / kk if v is not None and kk > 0.0 else None
        for i in range(n_r):
            lo, hi = rho_edges[i], rho_edges[i + 1]
            if rho_c is not None and v[2] < 0.0:
                lo = max(lo, rho_c)  # nothing is visible nearer the normal
                if hi <= lo:
                    out[i] = 0.0
                    continue
            pieces = []
            if rho_c is not None and lo < rho_c < hi and not math.isinf(hi):
                pieces.append(gauss_legendre(lo, rho_c, n_rho))
                lo = rho_c
            if math.isinf(hi):
                # rho = lo e^y on graded panels in y; the panel starting at rho_c by y = a + (b - a) u^2
                y_c = math.log(rho_c / lo) if rho_c is not None and rho_c >= lo else None
                edges = graded_edges(0.0, max(tail, 5.0) + 2.0, [] if y_c is None else [y_c])
                for a, b in zip(edges[:-1], edges[1:]):
                    if y_c is not None and a == y_c:
                        u, wu = gauss_legendre(0.0, 1.0, 16)
                        y, wy_ = a + (b - a) * u * u, wu * 2.0 * (b - a) * u
                    else:
                        y, wy_ = gauss_legendre(a, b, 16)
                    pieces.append((lo * np.exp(y), wy_ * lo * np.exp(y)))
            elif lo == rho_c:
                u, wu = gauss_legendre(0.0, 1.0, n_rho)
                pieces.append((lo + (hi - lo) * u * u, wu * 2.0 * (hi - lo) * u))
            else:
                pieces.append(gauss_legendre(lo, hi, n_rho))
            rho = np.concatenate([r for r, _ in pieces])
            w_rho = np.concatenate([w for _, w in pieces])
            # the cells' psi intervals, each cut to the positive arc at every rho node:
            # arrays (rho node, cell, shift) of [a, b]
            a = np.broadcast_to(psi_edges[None, :-1, None], (rho.size, psi_edges.size - 1, 1))
            b = np.broadcast_to(psi_edges[None, 1:, None], a.shape)
            if v is not None:
                if kk > 0.0:
                    c = np.clip(v[2] / (rho * kk), -1.0, 1.0)
                else:  # v along the normal: the whole circle (v_z > 0) or none of it
                    c = np.full(rho.shape, 1.0 if v[2] > 0.0 else -1.0)
                delta = np.arccos(c)  # positive where |psi - psi0| > delta (mod 2 pi)
                shifts = 2.0 * math.pi * np.arange(-2, 2)
                arc_lo = (psi0 + delta)[:, None, None] + shifts[None, None, :]
                arc_hi = (psi0 + 2.0 * math.pi - delta)[:, None, None] + shifts[None, None, :]
                a, b = np.maximum(a, arc_lo), np.minimum(b, arc_hi)
                b = np.maximum(a, b)
            psi, w_psi = gauss_legendre(a, b, n_psi)  # (rho node, cell, shift, node)
            r = rho[:, None, None, None]
            sx, sy = self.wx * r * np.cos(psi), self.wy * r * np.sin(psi)
            f = self.density(sx, sy)
            if v is not None:
                f = f * np.maximum(v[2] - v[0] * sx - v[1] * sy, 0.0)
            cell = np.einsum("rcsn,rcsn->rc", f, np.broadcast_to(w_psi, f.shape))
            out[i] = (w_rho * rho) @ cell * self.wx * self.wy
        return out


__all__ = ["Lobe", "TAIL_LEVEL", "direction", "gauss_legendre", "graded", "graded_edges"]
