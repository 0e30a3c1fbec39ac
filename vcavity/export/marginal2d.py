"""The continuous marginal-conditional warp of a bilinear interpolant on the unit square.

The RGL measured-BSDF format (Dupuy & Jakob 2018) stores a visible-normal distribution
as values at the nodes of a regular ``H x W`` grid on ``[0, 1]^2`` (``x`` along ``W``).
Readers (Mitsuba 3's ``Marginal2D<..., Continuous = true>``) interpolate the nodes
bilinearly into a density ``p(x, y)`` and map uniform points ``s`` to ``(x, y)`` by the
inverse CDF of the continuous marginal ``p(y) = ∫ p(x, y) dx``, then of the conditional
``p(x | y)``. That map is unique, so any exact implementation gives the same points; the
exporter needs it to place the colour grid at the warp's pre-images (docs/exports.md,
"RGL"). Within a patch the marginal is linear in ``y`` and the conditional linear in
``x``: each step inverts a quadratic (the "segment" solve below).

:func:`sample` is the forward warp, :func:`invert` its inverse (round trip tested), both
vectorised over points, for one data slice. Plain NumPy.
"""

from __future__ import annotations

import numpy as np


class Marginal2D:
    """The warp of one ``(H, W)`` slice of non-negative node values.

    Parameters
    ----------
    data : array_like, shape (H, W)
        Node values, ``H, W >= 2``, not all zero; row ``j`` is ``y = j/(H-1)``, column
        ``i`` is ``x = i/(W-1)``.
    """

    def __init__(self, data):
        values = np.asarray(data, dtype=np.float64)
        if values.ndim != 2 or min(values.shape) < 2:
            raise ValueError(f"data must be (H, W) with H, W >= 2, got shape {values.shape}")
        if not (np.all(np.isfinite(values)) and np.all(values >= 0.0)) or not np.any(values > 0.0):
            raise ValueError("data must be finite, non-negative and not all zero")
        h, w = values.shape
        self.dx, self.dy = 1.0 / (w - 1), 1.0 / (h - 1)
        # conditional CDF along x of every node row (trapezoids), and the row integrals
        cond = np.concatenate([np.zeros((h, 1)), np.cumsum(0.5 * self.dx * (values[:, 1:] + values[:, :-1]),
                                                           axis=1)], axis=1)
        row = cond[:, -1]
        marg = np.concatenate([[0.0], np.cumsum(0.5 * self.dy * (row[1:] + row[:-1]))])
        norm = marg[-1]
        self.data, self.cond, self.row, self.marg = values / norm, cond / norm, row / norm, marg / norm

    def pdf(self, x, y):
        """The normalised bilinear density at points ``(x, y)`` of the square."""
        ix, tx = _cell(np.clip(x, 0.0, 1.0), self.data.shape[1])
        iy, ty = _cell(np.clip(y, 0.0, 1.0), self.data.shape[0])
        d = self.data
        c0 = d[iy, ix] * (1 - ty) + d[iy + 1, ix] * ty
        c1 = d[iy, ix + 1] * (1 - ty) + d[iy + 1, ix + 1] * ty
        return c0 * (1 - tx) + c1 * tx

    def sample(self, s_x, s_y):
        """Forward warp of uniform points ``(s_x, s_y)`` to points ``(x, y)`` with density :meth:`pdf`.

        Returns
        -------
        x, y : ndarray
        """
        s_x = np.asarray(s_x, dtype=np.float64)
        s_y = np.asarray(s_y, dtype=np.float64)
        h, w = self.data.shape
        # row: the marginal CDF between node rows is quadratic (its density is linear)
        iy = np.clip(np.searchsorted(self.marg, s_y, side="right") - 1, 0, h - 2)
        r0, r1 = self.row[iy], self.row[iy + 1]
        ty = _solve_segment(s_y - self.marg[iy], self.dy, r0, r1)
        # column: the conditional CDF at that y, linear between the two node rows
        total = r0 + (r1 - r0) * ty
        target = s_x * total
        cdf_x = self.cond[iy] * (1 - ty)[..., None] + self.cond[iy + 1] * ty[..., None]
        ix = np.clip(np.sum(cdf_x <= target[..., None], axis=-1) - 1, 0, w - 2)
        c0 = _lerp_rows(self.data, iy, ix, ty)
        c1 = _lerp_rows(self.data, iy, ix + 1, ty)
        tx = _solve_segment(target - np.take_along_axis(cdf_x, ix[..., None], axis=-1)[..., 0], self.dx, c0, c1)
        return (ix + tx) * self.dx, (iy + ty) * self.dy

    def invert(self, x, y):
        """Inverse of :meth:`sample`: the uniform point that maps to ``(x, y)``.

        Returns
        -------
        s_x, s_y : ndarray
        """
        h, w = self.data.shape
        ix, tx = _cell(np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0), w)
        iy, ty = _cell(np.clip(np.asarray(y, dtype=np.float64), 0.0, 1.0), h)
        c0 = _lerp_rows(self.data, iy, ix, ty)
        c1 = _lerp_rows(self.data, iy, ix + 1, ty)
        before_x = self.cond[iy, ix] * (1 - ty) + self.cond[iy + 1, ix] * ty
        r0, r1 = self.row[iy], self.row[iy + 1]
        within_x = self.dx * tx * (c0 + 0.5 * (c1 - c0) * tx)
        total = r0 + (r1 - r0) * ty
        s_x = np.where(total > 0.0, (before_x + within_x) / np.where(total > 0.0, total, 1.0), 0.0)
        s_y = self.marg[iy] + self.dy * ty * (r0 + 0.5 * (r1 - r0) * ty)
        return s_x, s_y


def _cell(t, n):
    """Patch index in ``[0, n - 2]`` and fraction of coordinates ``t`` in ``[0, 1]``."""
    scaled = t * (n - 1)
    index = np.minimum(scaled.astype(np.int64), n - 2)
    return index, scaled - index


def _lerp_rows(data, iy, ix, ty):
    return data[iy, ix] * (1 - ty) + data[iy + 1, ix] * ty


def _solve_segment(mass, width, v0, v1):
    """``t`` in ``[0, 1]`` with ``width * (v0 t + (v1 - v0) t^2 / 2) = mass`` (a linear density)."""
    mass = np.maximum(mass, 0.0) / width
    slope = v1 - v0
    flat = np.abs(slope) <= 1e-9 * (v0 + v1)
    with np.errstate(divide="ignore", invalid="ignore"):
        # the root of slope t^2/2 + v0 t - mass in the cancellation-free form
        curved = 2.0 * mass / (v0 + np.sqrt(np.maximum(v0 * v0 + 2.0 * slope * mass, 0.0)))
        linear = mass / v0
    t = np.where(flat, np.where(v0 > 0, linear, 0.0), curved)
    return np.clip(np.nan_to_num(t, nan=0.0, posinf=1.0), 0.0, 1.0)
