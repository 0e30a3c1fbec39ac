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

The walk is the one slot loop of :mod:`vcavity.kernels.loop` with this module's per-path
tracer, as the V-groove walk's: per-block random streams, integer counts per thread slot,
one compiled variant per distribution x facet variant, cached on disk.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels.scaffold import ABSORBED, DEGENERATE, EXITED, TRUNCATED
from vcavity.microfacet import registry as distributions
from vcavity.rng.ziggurat import standard_exponential

#: The walk's name (:mod:`vcavity.kernels.registry`); its tallies and statistics are the
#: V-groove walk's, its paths weight 1.
NAME = "smith"
DESCRIPTION = "Smith's random walk (Heitz et al. 2016): uncorrelated heights and slopes"
TALLIES = ("counts",)
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned")
WEIGHTED = False


def prepare_direction(ix, iy, iz, params, dist_kind):
    """``Lambda(i)``: the first step's masking, the same for every path of a direction (the
    distribution's jitted ``smith_lambda``, called from Python once a walk call)."""
    return distributions.smith_lambda(dist_kind, ix, iy, iz, params)


@njit(cache=True, inline="always")
def trace_path(kind, state, ix, iy, iz, setup, params, dist_kind, facet_kind, facet_variant, facet_data,
               max_bounces, weight_scale):
    """Trace one path from the light into the Smith microsurface until it leaves or ends.

    ``lam_i`` is ``Lambda(i)``, the same for every path of a direction
    (:func:`prepare_direction`). Returns ``(state, outcome, bounces, wx, wy, wz, q)`` as the
    V-groove walk's :func:`vcavity.kernels.trace.trace_path` (``q = 0``: weight-1 paths).
    """
    lam_i = setup
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
            return state, TRUNCATED, k, 0.0, 0.0, 0.0, np.int64(0)
        k += 1
        state, mx, my, mz = distributions.sample_visible_stream(dist_kind, state, -wx, -wy, -wz, lam_v, params)
        cos_in = -(wx * mx + wy * my + wz * mz)
        if not cos_in > 0.0:  # a normal seen edge-on, by rounding
            return state, DEGENERATE, k, 0.0, 0.0, 0.0, np.int64(0)
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
            return state, ABSORBED, k, 0.0, 0.0, 0.0, np.int64(0)
        wx = cos_p * dx - sin_p * dy
        wy = sin_p * dx + cos_p * dy
    return state, EXITED, k, wx, wy, wz, np.int64(0)



#: None when the Smith walk can use a distribution, else why not (one line).
walkable = distributions.smith_walk_refusal


__all__ = ["NAME", "STATS", "TALLIES", "WEIGHTED", "prepare_direction", "trace_path", "walkable"]
