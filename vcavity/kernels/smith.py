"""The Smith random walk (Heitz, Hanika, d'Eon and Dachsbacher 2016; physics.md sec. 15):
the second microsurface beside the V-groove walk of :mod:`vcavity.kernels.trace`.

A Smith microsurface has uncorrelated heights and slopes. A ray inside it is a direction
``w`` and a height ``h``; the next facet it meets is found in two draws, the height of the
intersection (or escape) from the Smith masking of ``w`` and the facet normal from the
normals visible against ``w`` (:func:`vcavity.microfacet.registry.sample_visible_stream`). The
facet event is the same code as in the V-groove walk (:func:`vcavity.facet.registry.event`),
in a frame turned about ``z`` so that the facet normal lies in its x-z plane.

Heights enter only through ``C1(h)``, the share of the surface below ``h``: the walk keeps
``log C1(h)`` (0 above the surface), the uniform height distribution's ``log((h + 1)/2)``,
which makes plain that the result cannot depend on the height distribution (physics.md
sec. 15).

The kernel has the signature, results and reproducibility of the V-groove walk's
(:func:`vcavity.kernels.trace.get_kernel`): per-block random streams, integer counts per
thread slot, one compiled variant per distribution x facet variant, cached on disk.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.arrays import borrowed
from vcavity._numba.dispatch import apart
from vcavity._numba.jit import njit
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels.scaffold import (ABSORBED, DEGENERATE, EXITED, TRUNCATED, block_start, build_kernel,
                                      exit_buffers)
from vcavity.kernels.trace import (N_STATS, STAT_ABSORBED, STAT_DEGENERATE, STAT_MAX_BOUNCES, STAT_TRUNCATED,
                                   STAT_UNBINNED, STATS, TALLIES, arguments)
from vcavity.microfacet import registry as distributions
from vcavity.rng.ziggurat import standard_exponential
from vcavity.sensor.binning import bin_block

#: The walk's name (:mod:`vcavity.kernels.walks`); its tallies, statistics and arguments are
#: the V-groove walk's (TALLIES, STATS, arguments).
NAME = "smith"

# the walk counts a lost path in column STAT_ABSORBED + outcome - ABSORBED
assert (STAT_TRUNCATED, STAT_DEGENERATE) == (STAT_ABSORBED + TRUNCATED - ABSORBED, STAT_ABSORBED + DEGENERATE - ABSORBED)


@njit(cache=True, inline="always")
def _trace_smith_path(state, ix, iy, iz, lam_i, params, dist_kind, facet_kind, facet_variant, facet_data,
                      max_bounces):
    """Trace one path from the light into the Smith microsurface until it leaves or ends.

    ``lam_i`` is ``Lambda(i)``, the same for every path of a direction (computed once by the
    kernel). Returns ``(state, outcome, bounces, wx, wy, wz)`` as the V-groove walk's
    ``_trace_path``.
    """
    wx, wy, wz = -ix, -iy, -iz
    # log C1 of the current height, C1 the share of the surface below it (0: above all of it);
    # in logarithms a step costs an exponential deviate (no log) instead of two powers
    log_c = 0.0
    k = 0
    while True:
        state, e = standard_exponential(state)
        log_s = -e  # the log of a uniform on (0, 1], without a log (the ziggurat)
        # lam_v: Lambda of v = -w, the direction the next facet is seen from, which the
        # visible-normal sampler may use (Beckmann's does: C(mu) = mu (1 + Lambda(v)))
        if wz > 0.0:
            # travelling up: no facet in the way with probability G1 = c^Λ(w) (Heitz 2016 eq. 5);
            # else the facet's height has C1 = c / s^(1/Λ), s = 1 - u uniform above c^Λ.
            # log_c <= 0, so an upper bound of Λ that lets the ray out decides it without Λ
            # (Beckmann's bound needs no erfc; most rays leave here)
            bound = distributions.smith_lambda_bound(dist_kind, wx, wy, wz, params)
            if log_s < bound * log_c:
                break
            lam = distributions.smith_lambda_past_bound(dist_kind, bound, wx, wy, wz, params)
            if log_s < lam * log_c:
                break
            log_c -= log_s / lam
            lam_v = -1.0 - lam  # v below the horizon: Λ(v) = -1 - Λ(-v) (Heitz 2016 sec. 4.1)
        elif wz < 0.0:
            # travelling down it meets the surface surely; P(not above C1 = x) = (x/c)^(1 + Λ(-w));
            # the first step is the incident direction's, its Λ known
            lam_v = lam_i if k == 0 else distributions.smith_lambda(dist_kind, -wx, -wy, -wz, params)
            log_c += log_s / (1.0 + lam_v)
        else:
            lam_v = 0.0  # (a horizontal ray meets the surface at its own height; mu = 0)
        if k == max_bounces:
            return state, TRUNCATED, k, 0.0, 0.0, 0.0
        k += 1
        state, mx, my, mz = distributions.sample_visible_stream(dist_kind, state, -wx, -wy, -wz, lam_v, params)
        cos_in = -(wx * mx + wy * my + wz * mz)
        if not cos_in > 0.0:  # a normal seen edge-on, by rounding
            return state, DEGENERATE, k, 0.0, 0.0, 0.0
        # the facet frame: turned about z so that m = (sin θm, 0, cos θm)
        sin_m = math.sqrt(mx * mx + my * my)
        if sin_m > 0.0:
            cos_p, sin_p = mx / sin_m, my / sin_m
        else:
            cos_p, sin_p = 1.0, 0.0
        dx = cos_p * wx + sin_p * wy
        dy = cos_p * wy - sin_p * wx
        state, fate, dx, dy, wz = facets.event(facet_kind, facet_variant, state, dx, dy, wz, cos_in, sin_m, mz,
                                               facet_data)
        if fate == FACET_ABSORBED:
            return state, ABSORBED, k, 0.0, 0.0, 0.0
        wx = cos_p * dx - sin_p * dy
        wy = sin_p * dx + cos_p * dy
    return state, EXITED, k, wx, wy, wz


#: The path walk compiled apart from the kernel (as :data:`vcavity.kernels.trace.trace_path`).
trace_smith_path = apart(_trace_smith_path, __name__)


#: None when the Smith walk can use a distribution, else why not (one line).
walkable = distributions.smith_walk_refusal


def get_smith_kernel(dist_kind: int, facet_kind: int, facet_variant: int):
    """The kernel of the Smith walk for one distribution, facet model and facet variant.

    Signature, arguments and results as :func:`vcavity.kernels.trace.get_kernel`'s kernel.

    Raises
    ------
    ValueError
        The distribution cannot be walked (:func:`walkable`).
    """
    reason = walkable(distributions.MODULES[distributions.REGISTRY.check_kind(dist_kind, "get_smith_kernel")].NAME)
    if reason is not None:
        raise ValueError(reason)
    return build_kernel("smith_kernel", _make_smith_kernel, dist_kind, facet_kind, facet_variant, 1, N_STATS)


get_kernel = get_smith_kernel


def _make_smith_kernel(DIST, FACET, VARIANT, SOURCE_TAG):
    """The Python Smith walk of one slot of one scene, for :func:`vcavity.kernels.scaffold.build_kernel`."""

    def walk(slot, incident, direction_key, first_block, n_blocks, n_paths, params, facet_data,
             max_bounces, max_order, resolution, n_slots, first_binned_order, counts, stats, exits,
             exit_ints):
        # counts [max_order + 1, resolution**2] and stats [N_STATS]: this slot's rows, zeroed;
        # exits, exit_ints: its scratch rows (exit_buffers)
        _ = SOURCE_TAG  # part of the cache key; see vcavity.kernels.scaffold.SOURCE_TAG
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        lam_i = distributions.smith_lambda(DIST, ix, iy, iz, params)  # the first step's, every path's
        deepest = 0
        unbinned = 0
        exit_x, exit_y, exit_z, exit_row, exit_cell = exit_buffers(exits, exit_ints)
        walk_params = borrowed(params)  # no reference counting per path (_numba.arrays)
        walk_data = borrowed(facet_data)
        for b in range(slot, n_blocks, n_slots):
            state, n_here = block_start(direction_key, first_block, b, n_paths)
            n_exits = np.int64(0)  # not a literal 0: Numba would also compile bin_block for Literal[int](0)
            for _ in range(n_here):
                state, outcome, k, wx, wy, wz = trace_smith_path(
                    state, ix, iy, iz, lam_i, walk_params, DIST, FACET, VARIANT, walk_data, max_bounces)
                if k > deepest:  # not max(): one integer overload less to compile
                    deepest = k
                if outcome == EXITED:
                    if k < first_binned_order:
                        unbinned += 1
                    else:
                        exit_x[n_exits] = wx
                        exit_y[n_exits] = wy
                        exit_z[n_exits] = wz
                        exit_row[n_exits] = k if k <= max_order else 0
                        n_exits += 1
                else:  # the stats' first three columns are in the order of the outcome codes
                    stats[STAT_ABSORBED + outcome - ABSORBED] += 1
            bin_block(exit_x, exit_y, exit_z, n_exits, resolution, exit_cell)
            for j in range(n_exits):
                counts[exit_row[j], exit_cell[j]] += 1
        stats[STAT_MAX_BOUNCES] = deepest
        stats[STAT_UNBINNED] = unbinned

    return walk


__all__ = ["NAME", "STATS", "TALLIES", "arguments", "get_kernel", "get_smith_kernel", "walkable"]
