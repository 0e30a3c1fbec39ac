"""The specular term over the sensor cells near the mirror direction, for lobes narrower
than a cell (physics.md sec. 6-7; docs/validation.md, "Narrow specular lobes").

A cell integral of the specular term, ``∫_c f_s cos θ_o dω_o``, is a Gauss-Legendre rule
in the cell's square coordinates (:mod:`vcavity.analytic.cells`) as long as the lobe is
resolved by the nodes. A lobe much narrower than a cell (Beckmann alpha 1e-4, Phong
exponent 1e300) falls between them and its whole mass is lost. Near its peak the integral
is therefore taken in the half-vector domain instead, through the distribution's own
sampling map ``(u1, u2) -> m`` of pdf ``D(m)(m.n)`` (W eq. 14 and 24):

    ∫_c f_s cos θ_o dω_o = ∫∫ F(i.m) G2(i, o, m) (i.m) / ((i.n)(m.n)) [o(m) in c] du1 du2,

``o(m) = 2 (i.m) m - i`` (``dω_o = 4 (i.m) dω_m``, W eq. 14; ``D dω_m = du1 du2 / (m.n)``).
No D is evaluated, so the integrand stays bounded (``<= 2 F`` for V-cavity masking) for
any roughness down to 1e-300. Each ray ``u2 = const`` (``m`` tilts away from ``n`` as
``u1`` grows) is cut where ``o`` crosses a cell edge, the horizon, or a kink of G2; those
points are found by bisection on the sensor's own binning (:func:`vcavity.binning.direction_to_cell`),
so the cell a piece belongs to is the cell the simulator counts it in. Each piece is a
Gauss-Legendre rule in ``τ`` with ``u1 = sin^2(π τ / 2)``, which removes the square-root
behaviour of ``m`` at both ends of ``u1``. Per cell, the integrand over ``u2`` is smooth
between the rays through cell corners, so ``u2`` is split there and each piece gets a
Gauss-Legendre rule.

Only the cells of the peak region (:func:`peak_cells`: the 3 x 3 cells around the mirror
direction, and for an anisotropic lobe the cells its thin ridge crosses) are integrated this
way; beyond it the lobe varies on the scale of its distance from the peak, and the
sub-cell rule resolves it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from vcavity._jit import njit
from vcavity.analytic.terms import SMITH, VCAVITY, smith_lambda
from vcavity.binning import direction_to_cell, square_to_hemisphere
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.microfacet.common import g2_smith_height_correlated, g2_smith_separable

_HALF_PI = 0.5 * math.pi
#: Gauss-Legendre nodes per u2 piece and per tau piece (accuracy controls; the error is
#: estimated by halving them, :mod:`vcavity.analytic.exact_f1`).
DEFAULT_AZIMUTH_NODES = 8
DEFAULT_RADIAL_NODES = 8
#: Default absolute accuracy per cell of the azimuthal rule of the peak rays, and the most
#: halvings of a u2 piece.
DEFAULT_PEAK_TOLERANCE = 1e-10
MAX_DEPTH = 24
MAX_PIECES = 4096
#: A ray advances by at most this many sensor cell widths (in ``|Δo|``) per scan step, so
#: that it crosses each cell edge once per step and every crossing is bracketed.
_STEP_CELLS = 0.4
#: Longest scan step in tau.
_MAX_STEP = 1.0 / 32.0
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


@njit(cache=True, inline="always")
def _point(tau, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking, walter_fit, lambda_i,
           resolution):
    """State key and integrand at ``tau`` on the ray ``u2`` (see the module docstring).

    Returns ``(key, value, ox, oy, oz, tan_theta_m)``: ``key`` is ``-1`` where ``o`` is
    below the horizon or ``i.m <= 0`` (no single-bounce exit), else
    ``8 cell + regime`` with the V-cavity regime bits (``G1(i) < 1``, ``G1(o) < 1``,
    ``G1(o) < G1(i)``) marking the kinks of G2 (IL eq. 14). ``value`` is
    ``F G2 (i.m)/((i.n)(m.n)) du1/dtau``, ``du1/dtau = (π/2) sin(π tau)``.
    """
    s = math.sin(_HALF_PI * tau)
    mx, my, mz = distributions.sample_normal(kind, s * s, u2, params)
    tan_m = math.sqrt(max(1.0 - mz * mz, 0.0)) / mz if mz > 0.0 else math.inf
    im = ix * mx + iy * my + iz * mz
    ox = 2.0 * im * mx - ix
    oy = 2.0 * im * my - iy
    oz = 2.0 * im * mz - iz
    if im <= 0.0 or oz <= 0.0 or mz <= 0.0:
        return np.int64(-1), 0.0, ox, oy, oz, tan_m
    cell = direction_to_cell(ox, oy, oz, resolution)
    if masking == VCAVITY:
        g1_i = 2.0 * mz * iz / im
        g1_o = 2.0 * mz * oz / im  # o.m = i.m
        regime = (1 if g1_i < 1.0 else 0) + (2 if g1_o < 1.0 else 0) + (4 if g1_o < g1_i else 0)
        g = min(1.0, g1_i, g1_o)
    else:
        regime = 0
        lambda_o = smith_lambda(kind, ox, oy, oz, params, walter_fit)
        if masking == SMITH:
            g = g2_smith_separable(lambda_i, lambda_o)
        else:
            g = g2_smith_height_correlated(lambda_i, lambda_o)
    jacobian = _HALF_PI * math.sin(math.pi * tau)
    value = facets.reflectance(facet_kind, im, facet_data) * g * (im / iz) / mz * jacobian
    return cell * 8 + regime, value, ox, oy, oz, tan_m


@njit(cache=True)
def _ray(u2, incident, kind, params, facet_kind, facet_data, masking, walter_fit, lambda_i, resolution,
         slot_of_cell, n_slots, tan_stop, gl_x, gl_w):
    """Integrals of one ray ``u2`` over each peak cell (``slot_of_cell[c] >= 0``)."""
    ix, iy, iz = incident[0], incident[1], incident[2]
    out = np.zeros(n_slots)
    step_max = _STEP_CELLS / resolution
    tau = 0.0
    key_a, _, ax, ay, az, _ = _point(0.0, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                                     walter_fit, lambda_i, resolution)
    h = _MAX_STEP
    while tau < 1.0:
        tb = min(tau + h, 1.0)
        key_b, _, bx, by, bz, tan_b = _point(tb, u2, ix, iy, iz, kind, params, facet_kind, facet_data,
                                             masking, walter_fit, lambda_i, resolution)
        moved = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
        if moved > step_max and tb - tau > 1e-15:
            h = 0.5 * (tb - tau)
            continue
        # cut [tau, tb] where the state changes (each change bracketed, then bisected)
        t0 = tau
        key = key_a
        for _ in range(64):  # at most a few changes per step; the bound keeps it finite
            if key == key_b:
                break
            lo, hi = t0, tb
            while True:
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                key_mid = _point(mid, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                                 walter_fit, lambda_i, resolution)[0]
                if key_mid == key:
                    lo = mid
                else:
                    hi = mid
            _piece(out, key, t0, hi, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                   walter_fit, lambda_i, resolution, slot_of_cell, gl_x, gl_w)
            t0 = hi
            key = _point(hi, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking, walter_fit,
                         lambda_i, resolution)[0]
        _piece(out, key, t0, tb, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
               walter_fit, lambda_i, resolution, slot_of_cell, gl_x, gl_w)
        tau, key_a, ax, ay, az = tb, key_b, bx, by, bz
        if tan_b > tan_stop:  # beyond every peak cell (tan theta_m grows along the ray)
            break
        h = min(2.0 * h, _MAX_STEP)
    return out


@njit(cache=True, inline="always")
def _piece(out, key, t0, t1, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking, walter_fit,
           lambda_i, resolution, slot_of_cell, gl_x, gl_w):
    """Add the Gauss-Legendre integral over ``[t0, t1]`` of a piece of state ``key``."""
    if key < 0 or t1 <= t0:
        return
    slot = slot_of_cell[key // 8]
    if slot < 0:
        return
    half = 0.5 * (t1 - t0)
    centre = 0.5 * (t1 + t0)
    acc = 0.0
    for j in range(gl_x.shape[0]):
        acc += gl_w[j] * _point(centre + half * gl_x[j], u2, ix, iy, iz, kind, params, facet_kind,
                                facet_data, masking, walter_fit, lambda_i, resolution)[1]
    out[slot] += half * acc


@njit(cache=True, parallel=True)
def _rays(u2_nodes, u2_weights, incident, kind, params, facet_kind, facet_data, masking, walter_fit,
          resolution, slot_of_cell, n_slots, tan_stop, gl_x, gl_w):
    """``w_k ray(u2_k)`` per node ``k`` and peak cell."""
    lambda_i = 0.0 if masking == VCAVITY else smith_lambda(kind, incident[0], incident[1], incident[2],
                                                           params, walter_fit)
    per_ray = np.zeros((u2_nodes.shape[0], n_slots))
    for k in prange(u2_nodes.shape[0]):
        per_ray[k] = u2_weights[k] * _ray(u2_nodes[k], incident, kind, params, facet_kind, facet_data,
                                          masking, walter_fit, lambda_i, resolution, slot_of_cell,
                                          n_slots, tan_stop, gl_x, gl_w)
    return per_ray


@njit(cache=True)
def _corner_u2(hx, hy, kind, params, n_scan):
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
    flags = np.zeros((n_rays, resolution * resolution), dtype=np.bool_)
    step_max = _STEP_CELLS / resolution
    scale_min = min(scale_x, scale_y)
    for k in prange(n_rays):
        u2 = (k + 0.5) / n_rays
        tau = 0.0
        h = _MAX_STEP
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
            h = min(2.0 * h, _MAX_STEP)
            if mass * _GL_ERROR[-1] < min_error:  # nothing beyond can matter
                break
            if im <= 0.0 or oz <= 0.0 or mz <= 0.0:
                continue
            # local width of the lobe in o: |i + o| (= 2 i.m, the Jacobian of m -> o)
            # times its width in slope, alpha_min times the profile's width at radius T
            tx = mx / (mz * scale_x)
            ty = my / (mz * scale_y)
            width = 2.0 * im * scale_min * np.interp(math.sqrt(tx * tx + ty * ty), profile_t, profile_width)
            # the sub-cell rule's error on a lobe of that width, at most the mass beyond
            ratio = spacing / width if width > 0.0 else math.inf
            if mass * math.exp(np.interp(ratio, _GL_RATIO, _GL_LOG_ERROR)) > min_error:
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
    from vcavity.analytic.cells import MIN_SPECULAR_SUB

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
    return int(sensor.cell_index(np.array([[-incident[0], -incident[1], incident[2]]]))[0])


def _corners(cells, n):
    """Square coordinates of the distinct corners of ``cells``."""
    ix, iy = cells % n, cells // n
    corners = set()
    for dx in (0, 1):
        for dy in (0, 1):
            corners.update(zip((ix + dx).tolist(), (iy + dy).tolist()))
    k = np.array(sorted(corners), dtype=np.float64).reshape(-1, 2)
    return -1.0 + 2.0 * k[:, 0] / n, -1.0 + 2.0 * k[:, 1] / n


def azimuth_breaks(model, incident, sensor, cells) -> np.ndarray:
    """Sorted ``u2`` of the rays through the corners of ``cells`` (plus 0), in [0, 1)."""
    u, v = _corners(cells, sensor.resolution)
    breaks = [0.0]
    for uk, vk in zip(u, v):
        ox, oy, oz = square_to_hemisphere(float(uk), float(vk))
        hx, hy = incident[0] + ox, incident[1] + oy
        value = _corner_u2(hx, hy, model.kind, model.params, 256)
        if value >= 0.0:
            breaks.append(value)
    breaks = np.unique(np.asarray(breaks))
    return breaks


def peak_integrals(model, incident, sensor, cells, n_azimuth=DEFAULT_AZIMUTH_NODES,
                   n_radial=DEFAULT_RADIAL_NODES, tolerance=DEFAULT_PEAK_TOLERANCE, with_error=False):
    """``∫_c f_s cos θ_o dω_o`` for each of ``cells`` by rays in the half-vector domain.

    ``u2`` is split at the rays through the cells' corners (:func:`azimuth_breaks`);
    each piece gets an ``n_azimuth``-point Gauss-Legendre rule and is halved until the
    halves agree with the whole within ``tolerance`` times the piece's width in every
    cell (the sum of the accepted differences, at most ``tolerance`` per cell unless
    :data:`MAX_DEPTH` halvings or :data:`MAX_PIECES` pieces were not enough, is the
    azimuthal error estimate). The
    radial error is the change when ``n_radial`` is halved.

    Parameters
    ----------
    model : vcavity.analytic.SingleBounceModel
        Its distribution, facet and masking.
    incident : array_like (3,)
        Unit direction toward the light.
    sensor : EqualAreaSensor
    cells : array_like of int
        The cells (usually :func:`peak_cells`); every ray is followed until it is beyond
        all of them.
    n_azimuth, n_radial : int
        Gauss-Legendre nodes per ``u2`` piece and per ``tau`` piece.
    tolerance : float
        Absolute accuracy per cell of the azimuthal rule.
    with_error : bool
        Also return the error estimate per cell.

    Returns
    -------
    integrals : ndarray (len(cells),)
        Cosine-weighted integrals (dimensionless), in the order of ``cells``.
    error : ndarray (len(cells),)
        Only with ``with_error``: azimuthal plus radial error estimate (conservative:
        differences between a rule and its refinement).
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    cells = np.asarray(cells, dtype=np.int64)
    if not model.has_specular or cells.size == 0 or incident[2] <= 0.0:
        zeros = np.zeros(cells.size)
        return (zeros, zeros.copy()) if with_error else zeros
    slot_of_cell = np.full(sensor.n_cells, -1, dtype=np.int64)
    slot_of_cell[cells] = np.arange(cells.size)
    tan_stop = _tan_stop(incident, sensor, cells)
    x, w = np.polynomial.legendre.leggauss(int(n_azimuth))

    def pieces(lo, hi, n_radial):
        """Integral over each piece [lo_k, hi_k] of u2, shape (pieces, cells)."""
        half = 0.5 * (hi - lo)[:, None]
        nodes = (0.5 * (hi + lo)[:, None] + half * x[None, :]) % 1.0
        weights = half * w[None, :]
        gl_x, gl_w = np.polynomial.legendre.leggauss(int(n_radial))
        per_node = _rays(np.ascontiguousarray(nodes.ravel()), np.ascontiguousarray(weights.ravel()), incident,
                         model.kind, model.params, model.facet_kind, model.facet_data, model.masking_code,
                         model.lambda_fit, sensor.resolution, slot_of_cell, cells.size, tan_stop, gl_x, gl_w)
        return per_node.reshape(lo.size, x.size, cells.size).sum(axis=1)

    breaks = azimuth_breaks(model, incident, sensor, cells)
    ends = np.append(breaks, breaks[0] + 1.0)
    lo, hi = ends[:-1], ends[1:]
    keep = hi - lo > 1e-15
    lo, hi = lo[keep], hi[keep]
    whole = pieces(lo, hi, n_radial)
    total = np.zeros(cells.size)
    error = np.zeros(cells.size)
    accepted = []
    for depth in range(MAX_DEPTH + 1):
        mid = 0.5 * (lo + hi)
        halves = pieces(np.concatenate([lo, mid]), np.concatenate([mid, hi]), n_radial)
        refined = halves[:lo.size] + halves[lo.size:]
        difference = np.abs(refined - whole)
        done = np.all(difference <= tolerance * (hi - lo)[:, None], axis=1)
        if depth == MAX_DEPTH or 2 * np.count_nonzero(~done) > MAX_PIECES:  # bounded cost
            done[:] = True
        total += refined[done].sum(axis=0)
        error += difference[done].sum(axis=0)
        accepted.append((lo[done], hi[done]))
        if np.all(done):
            break
        lo, hi = np.concatenate([lo[~done], mid[~done]]), np.concatenate([mid[~done], hi[~done]])
        whole = np.concatenate([halves[:mid.size][~done], halves[mid.size:][~done]])
    if not with_error:
        return total
    if int(n_radial) >= 2:
        # radial error: the same pieces with half the tau nodes
        lo_all = np.concatenate([a for a, _ in accepted])
        hi_all = np.concatenate([b for _, b in accepted])
        mid = 0.5 * (lo_all + hi_all)
        coarse = pieces(np.concatenate([lo_all, mid]), np.concatenate([mid, hi_all]), max(int(n_radial) // 2, 1))
        error += np.abs(coarse.sum(axis=0) - total)
    return total, error


def _tan_stop(incident, sensor, cells):
    """1.5 x the largest ``tan θ_h`` at the nodes and corners of ``cells``: beyond it a ray
    (``tan θ_m`` grows along it) reaches none of them."""
    from vcavity.analytic.quadrature import subcell_quadrature
    from vcavity.sensor import square_to_hemisphere_array

    directions, _ = subcell_quadrature(sensor, 4, cells=cells)
    u, v = _corners(cells, sensor.resolution)
    points = np.concatenate([directions.reshape(-1, 3), square_to_hemisphere_array(u, v)])
    h = points + incident[None, :]
    tan_h = np.hypot(h[:, 0], h[:, 1]) / np.maximum(h[:, 2], 1e-300)
    return 1.5 * float(np.max(tan_h)) + 1e-300


__all__ = ["peak_integrals", "peak_cells", "azimuth_breaks", "mirror_cell", "DEFAULT_AZIMUTH_NODES",
           "DEFAULT_RADIAL_NODES", "SCAN_RAYS"]
