"""Which sensor cells need the half-vector rule of :mod:`vcavity.analytic.specular_peak`.

A lobe narrower than the sub-cell Gauss-Legendre rule of :mod:`vcavity.analytic.cells`
resolves is integrated over the half vector near its peak. :func:`peak_cells` finds those
cells by a scan of rays ``u2 = const`` of the distribution's own sampling map (physics.md
sec. 6-7; docs/validation.md, "Narrow specular lobes"): a point marks its cell when the
sub-cell rule's measured error on a lobe of the local width, times the lobe's mass
beyond the point, could exceed :data:`MARK_ERROR`. :func:`corner_u2` gives the ray through
a cell corner (the azimuthal breaks of the peak integrals); :func:`mirror_cell` the cell of
the mirror direction.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from vcavity._numba.arrays import filled
from vcavity._numba.interp import interp
from vcavity._numba.jit import njit
from vcavity.analytic.quadrature import MAX_STEP, MIN_SPECULAR_SUB, STEP_CELLS
from vcavity.sensor.binning import cell_index, direction_to_cell
from vcavity.microfacet import registry as distributions

_HALF_PI = 0.5 * math.pi
#: Error of a 16-point Gauss-Legendre rule on a Gaussian lobe, relative to the lobe's
#: mass, against the rule's spacing in units of the lobe's width (sigma): measured over
#: all positions of the lobe in the cell (docs/validation.md); beyond 2, the whole mass.
_GL_RATIO = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 1e300])
_GL_ERROR = np.array([1e-16, 1e-15, 4e-10, 5e-6, 7e-4, 5e-2, 1.0, 1.0])
_GL_LOG_ERROR = np.log(_GL_ERROR)
_CELL_STRETCH = 1.6
#: A point of the scan marks its cell when the sub-cell rule's error on the lobe there,
#: times the lobe's mass beyond the point, could exceed this (absolute, per path).
MARK_ERROR = 1e-11
#: Rays of the scan that finds the peak cells (:func:`peak_cells`).
SCAN_RAYS = 128


@njit(cache=True)
def corner_u2(hx, hy, kind, params, n_scan):
    """The ``u2`` whose sampled normals have the azimuth of ``(hx, hy)``, or -1.

    Every registered sampler moves ``m`` along a fixed azimuth as ``u1`` grows (stretched
    slopes, H sec. 5), so the azimuth at ``u1 = 1/2`` identifies the ray; it is found by
    a scan of ``n_scan`` values and bisection on the sign of the cross product.
    """
    norm = math.sqrt(hx * hx + hy * hy)
    if norm <= 1e-300:
        return -1.0
    hx, hy = hx / norm, hy / norm
    prev_u2 = 0.0
    mx, my, _ = distributions.sample_normal(kind, 0.5, 0.0, params)
    prev_cross = mx * hy - my * hx
    for k in range(1, n_scan + 1):
        u2 = k / n_scan
        mx, my, _ = distributions.sample_normal(kind, 0.5, u2, params)
        cross = mx * hy - my * hx
        aligned = mx * hx + my * hy > 0.0
        if aligned and (cross == 0.0 or (cross > 0.0) != (prev_cross > 0.0)):
            lo, hi = prev_u2, u2
            lo_positive = prev_cross > 0.0
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                mx, my, _ = distributions.sample_normal(kind, 0.5, mid, params)
                if (mx * hy - my * hx > 0.0) == lo_positive:
                    lo = mid
                else:
                    hi = mid
            return 0.5 * (lo + hi) % 1.0
        prev_u2, prev_cross = u2, cross
    return -1.0


@njit(cache=True, parallel=True)
def _scan(incident, kind, params, scale_x, scale_y, profile_t, profile_width, resolution, n_rays, spacing,
          min_error):
    """Cells that ``n_rays`` rays ``u2 = (k + 1/2)/n_rays`` visit where the lobe is finer
    than the sub-cell rule resolves (see :func:`peak_cells`); one row of flags per ray."""
    ix, iy, iz = incident[0], incident[1], incident[2]
    flags = filled(np.empty((n_rays, resolution * resolution), dtype=np.bool_), False)  # not np.zeros (_numba.arrays)
    step_max = STEP_CELLS / resolution
    scale_min = min(scale_x, scale_y)
    for k in prange(n_rays):
        u2 = (k + 0.5) / n_rays
        tau = 0.0
        h = MAX_STEP
        ax, ay, az = -ix, -iy, iz
        while tau < 1.0:
            tb = min(tau + h, 1.0)
            c = math.cos(_HALF_PI * tb)
            mass = c * c  # 1 - u1: the lobe's mass beyond this point of the ray
            s = math.sin(_HALF_PI * tb)
            mx, my, mz = distributions.sample_normal(kind, s * s, u2, params)
            im = ix * mx + iy * my + iz * mz
            ox, oy, oz = 2.0 * im * mx - ix, 2.0 * im * my - iy, 2.0 * im * mz - iz
            moved = math.sqrt((ox - ax) ** 2 + (oy - ay) ** 2 + (oz - az) ** 2)
            if moved > step_max and tb - tau > 1e-15:
                h = 0.5 * (tb - tau)
                continue
            tau, ax, ay, az = tb, ox, oy, oz
            h = min(2.0 * h, MAX_STEP)
            if mass * _GL_ERROR[-1] < min_error:  # nothing beyond can matter
                break
            if im <= 0.0 or oz <= 0.0 or mz <= 0.0:
                continue
            # local width of the lobe in o: |i + o| (= 2 i.m, the Jacobian of m -> o)
            # times its width in slope, alpha_min times the profile's width at radius T
            tx = mx / (mz * scale_x)
            ty = my / (mz * scale_y)
            width = 2.0 * im * scale_min * interp(math.sqrt(tx * tx + ty * ty), profile_t, profile_width)
            # the sub-cell rule's error on a lobe of that width, at most the mass beyond
            ratio = spacing / width if width > 0.0 else math.inf
            if mass * math.exp(interp(ratio, _GL_RATIO, _GL_LOG_ERROR)) > min_error:
                flags[k, direction_to_cell(ox, oy, oz, resolution)] = True
    return flags


def _scales(model):
    """Slope scales of the stretched radius ``T``: ``alpha_x, alpha_y``, else the lobe width."""
    values = model.material.distribution_params
    return (float(values.get("alpha_x", model.lobe_width)), float(values.get("alpha_y", model.lobe_width)))


def _profile(model, n=2048):
    """Width of the lobe's slope density at stretched radius ``T``, in units of alpha.

    From the sampler (``u1`` is the radial CDF): ``f(T) = (du1/dT) / (2 π T)`` is the
    density in the stretched slope plane, and its local width is
    ``1 / sqrt(max(|g''|, |g'| / T, g'^2))`` with ``g = log f`` (curvature along and
    across the radius, and the gradient): ``1/(2T)`` for Beckmann's ``exp(-T^2)``, about
    ``T/2`` for the GGX tail. Tabulated on ``u1 = sin^2(π τ / 2)``, ``τ`` uniform.
    """
    cached = getattr(model, "_peak_profile", None)
    if cached is not None:
        return cached
    tau = (np.arange(1, n) / n)
    u1 = np.sin(0.5 * np.pi * tau) ** 2
    m = distributions.sample_normals(model.kind, u1, np.zeros_like(u1), model.params)
    scale_x, scale_y = _scales(model)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.hypot(m[:, 0] / (m[:, 2] * scale_x), m[:, 1] / (m[:, 2] * scale_y))
    keep = np.concatenate([[True], np.diff(t) > 0.0]) & np.isfinite(t) & (t > 0.0)
    t, u1 = t[keep], u1[keep]
    if t.size < 8:  # the whole lobe below float resolution: any width is resolved by rays
        profile = (np.array([0.0, 1.0]), np.array([1.0, 1.0]))
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            log_f = np.log(np.gradient(u1, t)) - np.log(t)
            g1 = np.gradient(log_f, t)
            g2 = np.gradient(g1, t)
            width = 1.0 / np.sqrt(np.maximum.reduce([np.abs(g2), np.abs(g1) / t, g1 * g1, np.full(t.size, 1e-300)]))
        good = np.isfinite(width)
        if not np.any(good):
            profile = (np.array([0.0, 1.0]), np.array([1.0, 1.0]))
        else:
            # repeated or unresolved nodes: the narrowest width met elsewhere (conservative)
            width = np.where(good, width, np.min(width[good]))
            # near T = 0 the finite differences are noisy: the width there is the width at small T
            profile = (np.concatenate([[0.0], t]), np.concatenate([[width[min(4, width.size - 1)]], width]))
    model._peak_profile = profile
    return profile


def peak_cells(model, incident, sensor) -> np.ndarray:
    """Cells whose specular integral is taken by rays (sorted indices; often empty).

    A ray scan (:data:`SCAN_RAYS` rays) marks the cells where the ``MIN_SPECULAR_SUB``-point
    sub-cell rule (:mod:`vcavity.analytic.cells`) could miss more than :data:`MARK_ERROR`
    of the lobe: its measured error on a lobe of the local width (``_GL_ERROR``, for the
    spacing on the longest cell side) times the mass of the lobe beyond the point (``1 - u1``
    along the ray). The local width is ``|i + o|`` (``= 2 i.m``, the Jacobian
    of ``m -> o``, W eq. 14) times ``alpha_min`` times the width of the lobe's slope
    density at the point's stretched slope radius (:func:`_profile`). That catches a
    lobe narrower than a cell (its 3 x 3 cells), an anisotropic ridge (the cells it
    crosses) and the wedge any lobe becomes at grazing incidence (``|i + o| -> 2 cos θ_i``
    near the mirror direction). The marked cells, their neighbours and the 3 x 3 cells
    around the mirror direction are returned; nothing when no cell is marked. The set
    does not depend on the rules used elsewhere, so refining those leaves it unchanged.
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    if not model.has_specular or incident[2] <= 0.0:
        return np.zeros(0, dtype=np.int64)
    n = sensor.resolution
    # the longest side of a cell spans up to 1.6 x the mean angle (near the horizon, physics.md sec. 9)
    spacing = _CELL_STRETCH * math.sqrt(2.0 * math.pi) / n / MIN_SPECULAR_SUB
    scale_x, scale_y = _scales(model)
    profile_t, profile_width = _profile(model)
    flags = _scan(incident, model.kind, model.params, scale_x, scale_y, profile_t, profile_width, n, SCAN_RAYS,
                  spacing, MARK_ERROR).any(axis=0).reshape(n, n)
    if not flags.any():
        return np.zeros(0, dtype=np.int64)
    grown = flags.copy()
    grown[1:, :] |= flags[:-1, :]
    grown[:-1, :] |= flags[1:, :]
    grown2 = grown.copy()
    grown2[:, 1:] |= grown[:, :-1]
    grown2[:, :-1] |= grown[:, 1:]
    peak = mirror_cell(incident, sensor)
    px, py = peak % n, peak // n
    grown2[max(py - 1, 0):py + 2, max(px - 1, 0):px + 2] = True
    return np.flatnonzero(grown2.ravel()).astype(np.int64)


def mirror_cell(incident, sensor) -> int:
    """Cell of the mirror direction ``(-i_x, -i_y, i_z)``."""
    return int(cell_index(sensor, np.array([[-incident[0], -incident[1], incident[2]]]))[0])
