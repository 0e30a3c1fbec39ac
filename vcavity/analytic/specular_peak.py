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
points are found by bisection on the sensor's own binning (:func:`vcavity.sensor.binning.direction_to_cell`),
so the cell a piece belongs to is the cell the simulator counts it in. Each piece is a
Gauss-Legendre rule in ``τ`` with ``u1 = sin^2(π τ / 2)``, which removes the square-root
behaviour of ``m`` at both ends of ``u1``. Per cell, the integrand over ``u2`` is smooth
between the rays through cell corners, so ``u2`` is split there and each piece gets a
Gauss-Legendre rule.

Only the cells of the peak region (:func:`vcavity.analytic.peak_cells.peak_cells`: the 3 x 3 cells around the mirror
direction, and for an anisotropic lobe the cells its thin ridge crosses) are integrated this
way; beyond it the lobe varies on the scale of its distance from the peak, and the
sub-cell rule resolves it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from vcavity._numba.jit import njit
from vcavity.analytic.peak_cells import corner_u2
from vcavity.analytic.quadrature import MAX_STEP, STEP_CELLS, subcell_quadrature
from vcavity.analytic.terms import SMITH, VCAVITY, smith_lambda
from vcavity.sensor.binning import direction_to_cell, square_to_hemisphere
from vcavity.sensor.grid import square_to_hemisphere_array
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
    step_max = STEP_CELLS / resolution
    tau = 0.0
    key_a, _, ax, ay, az, _ = _point(0.0, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                                     walter_fit, lambda_i, resolution)
    h = MAX_STEP
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
        h = min(2.0 * h, MAX_STEP)
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
        value = corner_u2(hx, hy, model.kind, model.params, 256)
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
    directions, _ = subcell_quadrature(sensor, 4, cells=cells)
    u, v = _corners(cells, sensor.resolution)
    points = np.concatenate([directions.reshape(-1, 3), square_to_hemisphere_array(u, v)])
    h = points + incident[None, :]
    tan_h = np.hypot(h[:, 0], h[:, 1]) / np.maximum(h[:, 2], 1e-300)
    return 1.5 * float(np.max(tan_h)) + 1e-300


__all__ = ["peak_integrals", "azimuth_breaks", "DEFAULT_AZIMUTH_NODES", "DEFAULT_RADIAL_NODES"]
