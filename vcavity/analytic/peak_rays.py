"""The rays of the half-vector rule of :mod:`vcavity.analytic.specular_peak`, walked in
jitted code (physics.md sec. 6-7; docs/validation.md, "Narrow specular lobes").

A ray ``u2 = const`` of the distribution's sampler (``m`` tilts away from ``n`` as ``u1``
grows) is walked in ``τ`` (``u1 = sin^2(π τ / 2)``) with steps of at most
:data:`~vcavity.analytic.quadrature.STEP_CELLS` cell widths in ``o``. Each step is cut
where ``o`` changes state (cell, horizon, a kink of G2), found by bisection on the
sensor's own binning, and each piece of a peak cell gets a Gauss-Legendre rule in ``τ``.

Bisection finds *a* change of state in a step, so a step must not leave a cell and come
back: a ray nearly tangent to a cell edge dips across it and back within one step, and
the dip (in a neighbouring cell) was credited to the cell the step began in. Cells are
rectangles in the sensor's square coordinates ``(u, v)``, so a path along which ``u`` and
``v`` are both monotone enters each cell at most once: every step is therefore cut at the
interior extrema of ``u`` and ``v`` along it (located by successive parabolic
interpolation), where a dip is deepest, and bisection works on each monotone part.

:func:`_rays` gives the weighted integrals of many rays; :func:`_signatures` a hash of
the states each ray passes through (the pieces it is cut into), which tells where the
integrals stop being smooth functions of ``u2`` (:func:`vcavity.analytic.specular_peak.event_breaks`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from vcavity._numba.jit import njit
from vcavity.analytic.batches import in_batches
from vcavity.analytic.quadrature import MAX_STEP, STEP_CELLS
from vcavity.analytic.terms import SMITH, VCAVITY, smith_lambda
from vcavity.sensor.binning import direction_to_cell, hemisphere_to_square
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.microfacet.common import g2_smith_height_correlated, g2_smith_separable

_HALF_PI = 0.5 * math.pi
#: Start and multiplier of the FNV-1a-like hash of a ray's transitions (64-bit, wrapping).
_HASH_START = 1469598103934665603
_HASH_PRIME = 1099511628211
#: Parabolic steps that locate an extremum of ``u`` or ``v`` inside a step.
EXTREMUM_STEPS = 3
#: Rays of the first compiled call of :func:`_rays` and :func:`_signatures` (the later
#: calls are sized by time, :mod:`vcavity.analytic.batches`).
_FIRST_RAYS = 64


# _point and _square are compiled once each and inlined by LLVM (``forceinline``), not
# IR-inlined by Numba (``inline="always"``): _walk and _piece call _point at seven places, and
# each IR copy carried the run-time chains over every distribution's sample_normal and
# smith_lambda and every facet's reflectance through Numba's passes (the cold compile this
# saves: docs/performance.md, "Figures from the code's comments").
@njit(cache=True, forceinline=True)
def _point(tau, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking, walter_fit, lambda_i,
           resolution):
    """State key and integrand at ``tau`` on the ray ``u2`` (see the module docstring).

    Returns ``(key, value, ox, oy, oz, tan_theta_m)``: ``key`` is ``-1`` where ``o`` is
    below the horizon or ``i.m <= 0`` (no single-bounce exit), else
    ``8 cell + regime`` with the V-cavity regime bits (``G1(i) < 1``, ``G1(o) < 1``,
    ``G1(o) < G1(i)``) marking the kinks of G2 (IL eq. 14). ``value`` is
    ``F G2 (i.m)/((i.n)(m.n)) du1/dtau``, ``du1/dtau = (π/2) sin(π tau)`` (W eq. 14, 24).
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


@njit(cache=True, forceinline=True)
def _square(tau, u2, ix, iy, iz, kind, params):
    """Square coordinates ``(u, v)`` of ``o`` at ``tau`` on the ray ``u2`` (physics.md sec. 6)."""
    s = math.sin(_HALF_PI * tau)
    mx, my, mz = distributions.sample_normal(kind, s * s, u2, params)
    im = ix * mx + iy * my + iz * mz
    return hemisphere_to_square(2.0 * im * mx - ix, 2.0 * im * my - iy, max(2.0 * im * mz - iz, 0.0))


@njit(cache=True)
def _extremum(t1, f1, t2, f2, t3, f3, which, u2, ix, iy, iz, kind, params):
    """``tau`` of the extremum of coordinate ``which`` (0: u, 1: v) inside ``(t1, t3)``, or -1.

    The parabola through the three points; when its vertex lies inside, it is improved by
    :data:`EXTREMUM_STEPS` steps of successive parabolic interpolation (the vertex and its
    two neighbours among the points so far).
    """
    best = -1.0
    for _ in range(EXTREMUM_STEPS + 1):
        d1, d3 = t2 - t1, t2 - t3
        denominator = d1 * (f2 - f3) - d3 * (f2 - f1)
        if denominator == 0.0:
            return best
        vertex = t2 - 0.5 * (d1 * d1 * (f2 - f3) - d3 * d3 * (f2 - f1)) / denominator
        if not (t1 < vertex < t3) or vertex == t2:
            return best
        best = vertex
        coordinates = _square(vertex, u2, ix, iy, iz, kind, params)
        fv = coordinates[which]
        if vertex < t2:
            t1, f1, t2, f2, t3, f3 = (t1, f1, vertex, fv, t2, f2) if _between(f1, fv, f2) else (vertex, fv, t2, f2, t3, f3)
        else:
            t1, f1, t2, f2, t3, f3 = (t2, f2, vertex, fv, t3, f3) if _between(f2, fv, f3) else (t1, f1, t2, f2, vertex, fv)
    return best


@njit(cache=True, inline="always")
def _between(fa, fm, fb):
    """Whether ``fm`` is beyond both ``fa`` and ``fb`` (an extremum bracketed at the middle)."""
    return (fm - fa) * (fm - fb) > 0.0


@njit(cache=True, inline="always")
def _state(key, slot_of_cell):
    """The state of a key for the signature: ``8 slot + regime`` in a peak cell, ``-2 - cell``
    in another cell (its regime does not matter), -1 for no exit. The hash takes the
    transitions into and out of peak cells, with the other cell's identity, so that a dip
    into one neighbour appearing while a dip into another disappears still changes it,
    and nothing that happens beyond the peak cells does."""
    if key < 0:
        return np.int64(-1)
    if slot_of_cell[key // 8] < 0:
        return -2 - key // 8
    return slot_of_cell[key // 8] * 8 + key % 8


@njit(cache=True)
def _walk(u2, incident, kind, params, facet_kind, facet_data, masking, walter_fit, lambda_i, resolution,
          slot_of_cell, n_slots, tan_stop, gl_x, gl_w, integrate):
    """Walk one ray ``u2``: its integrals over each peak cell (``slot_of_cell[c] >= 0``; only
    with ``integrate``) and the hash of its transitions into and out of peak cells (:func:`_state`)."""
    ix, iy, iz = incident[0], incident[1], incident[2]
    out = np.zeros(n_slots)
    step_max = STEP_CELLS / resolution
    tau = 0.0
    key_a, _, ax, ay, az, _ = _point(0.0, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                                     walter_fit, lambda_i, resolution)
    state = _state(key_a, slot_of_cell)
    digest = np.int64(_HASH_START) ^ state
    h = MAX_STEP
    while tau < 1.0:
        tb = min(tau + h, 1.0)
        key_b, _, bx, by, bz, tan_b = _point(tb, u2, ix, iy, iz, kind, params, facet_kind, facet_data,
                                             masking, walter_fit, lambda_i, resolution)
        moved = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2)
        # near the horizon G2 changes on the scale of o_z itself (Smith: Lambda(o) ~ 1/o_z), which
        # at grazing incidence (o_z = i_z at the ray's start) is far finer than a cell
        near = max(min(max(az, 0.0), max(bz, 0.0)), iz)
        if (moved > step_max or abs(bz - az) > near) and tb - tau > 1e-15:
            h = 0.5 * (tb - tau)
            continue
        # cut the step where u or v turns (module docstring): each part is monotone
        ua, va = hemisphere_to_square(ax, ay, max(az, 0.0))
        ub, vb = hemisphere_to_square(bx, by, max(bz, 0.0))
        tm = 0.5 * (tau + tb)
        um, vm = _square(tm, u2, ix, iy, iz, kind, params)
        cut_u = _extremum(tau, ua, tm, um, tb, ub, 0, u2, ix, iy, iz, kind, params)
        cut_v = _extremum(tau, va, tm, vm, tb, vb, 1, u2, ix, iy, iz, kind, params)
        first, second = min(cut_u, cut_v), max(cut_u, cut_v)
        t0, key = tau, key_a
        for part in range(3):
            t_end = first if part == 0 else (second if part == 1 else tb)
            if not (t0 < t_end <= tb):
                continue
            key_end = key_b if part == 2 else _point(t_end, u2, ix, iy, iz, kind, params, facet_kind, facet_data,
                                                     masking, walter_fit, lambda_i, resolution)[0]
            # cut [t0, t_end] where the state changes (each change bracketed, then bisected)
            for _ in range(64):  # at most a few changes per part; the bound keeps it finite
                if key == key_end:
                    break
                lo, hi = t0, t_end
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
                if integrate:
                    _piece(out, key, t0, hi, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                           walter_fit, lambda_i, resolution, slot_of_cell, gl_x, gl_w)
                t0 = hi
                key = _point(hi, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking, walter_fit,
                             lambda_i, resolution)[0]
                following = _state(key, slot_of_cell)
                if following != state:
                    if following >= 0 or state >= 0:  # into or out of a peak cell: the rest cannot matter
                        digest = (digest ^ (state * np.int64(1000003) + following)) * np.int64(_HASH_PRIME)
                    state = following
            if integrate:
                _piece(out, key, t0, t_end, u2, ix, iy, iz, kind, params, facet_kind, facet_data, masking,
                       walter_fit, lambda_i, resolution, slot_of_cell, gl_x, gl_w)
            t0, key = t_end, key_end
        tau, key_a, ax, ay, az = tb, key_b, bx, by, bz
        if tan_b > tan_stop:  # beyond every peak cell (tan theta_m grows along the ray)
            break
        h = min(2.0 * h, MAX_STEP)
    return out, digest


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


@njit(cache=True)
def _lambda_i(incident, kind, params, masking, walter_fit):
    return 0.0 if masking == VCAVITY else smith_lambda(kind, incident[0], incident[1], incident[2], params,
                                                       walter_fit)


@njit(cache=True, parallel=True)
def _walk_rays(u2_nodes, u2_weights, incident, kind, params, facet_kind, facet_data, masking, walter_fit,
               resolution, slot_of_cell, n_slots, tan_stop, gl_x, gl_w, integrate):
    """Per node ``k``: ``w_k ray(u2_k)`` per peak cell (with ``integrate``) and the ray's state hash.

    One compiled driver for both uses, ``integrate`` a run-time flag: with a literal flag
    in two drivers Numba compiled :func:`_walk` twice (the cost: docs/performance.md,
    "Figures from the code's comments").
    """
    lambda_i = _lambda_i(incident, kind, params, masking, walter_fit)
    # every row is written below; np.zeros would be a parallel loop of its own (_numba.arrays)
    per_ray = np.empty((u2_nodes.shape[0], n_slots))
    digests = np.empty(u2_nodes.shape[0], dtype=np.int64)
    for k in prange(u2_nodes.shape[0]):
        values, digest = _walk(u2_nodes[k], incident, kind, params, facet_kind, facet_data, masking, walter_fit,
                               lambda_i, resolution, slot_of_cell, n_slots, tan_stop, gl_x, gl_w, integrate)
        per_ray[k] = u2_weights[k] * values
        digests[k] = digest
    return per_ray, digests


def _rays(u2_nodes, u2_weights, incident, kind, params, facet_kind, facet_data, masking, walter_fit,
          resolution, slot_of_cell, n_slots, tan_stop, gl_x, gl_w, should_stop=None):
    """``w_k ray(u2_k)`` per node ``k`` and peak cell, in batches of rays
    (:func:`vcavity.analytic.batches.in_batches`: each ray is its own)."""
    out = np.empty((u2_nodes.shape[0], n_slots))

    def batch(start, stop):
        out[start:stop] = _walk_rays(u2_nodes[start:stop], u2_weights[start:stop], incident, kind, params,
                                     facet_kind, facet_data, masking, walter_fit, resolution, slot_of_cell, n_slots,
                                     tan_stop, gl_x, gl_w, True)[0]

    in_batches(u2_nodes.shape[0], _FIRST_RAYS, batch, should_stop, minimum=numba.get_num_threads())
    return out


def _signatures(u2_nodes, incident, kind, params, facet_kind, facet_data, masking, walter_fit, resolution,
                slot_of_cell, tan_stop, gl_x, gl_w, should_stop=None):
    """The state hash of each ray (:func:`_walk` without integrating), in batches of rays."""
    out = np.empty(u2_nodes.shape[0], dtype=np.int64)
    weights = np.ones_like(u2_nodes)

    def batch(start, stop):
        out[start:stop] = _walk_rays(u2_nodes[start:stop], weights[start:stop], incident, kind, params, facet_kind,
                                     facet_data, masking, walter_fit, resolution, slot_of_cell, 0, tan_stop, gl_x,
                                     gl_w, False)[1]

    in_batches(u2_nodes.shape[0], _FIRST_RAYS, batch, should_stop, minimum=numba.get_num_threads())
    return out
