"""The IL paper's own estimator (IL eq. 23, physics.md sec. 11): start on a facet, weight
by its lit projected area.

Instead of entering the groove through a uniform point of its opening, a path starts at a
uniform point ``x`` of one of the groove's two facets (each with probability 1/2). Light
from ``i`` reaches that point with flux density ``(i.m_f) V(x)`` per unit facet length
(``V`` = 1 when the segment from ``x`` toward the light leaves through the opening), while
the light entering the opening (width 2) carries ``2 (i.n)``; the facet has length
``L = 1 / (m.n)``. The path's weight is the ratio of the two densities,

    w = (i.m_f) V(x) / ((i.n) (m.n)),        E[w] = 1,

so back-facing and shadowed starting points have weight 0 and are not traced. From the
first event on, the walk is the uniform-entry walk of :mod:`vcavity.kernels.trace`.

Weights are summed as integers: ``q = floor(w Q + u)`` with the estimator's fixed-point
scale ``Q`` (:data:`vcavity.estimators.paper.WEIGHT_SCALE`, passed in) and a fresh
uniform ``u`` (stochastic rounding, so ``E[q] / Q = w`` exactly), and ``q^2`` for the
variance. Merging stays exact in any order, so tables do not depend on threads or
chunking. The walk is the one slot loop of :mod:`vcavity.kernels.loop` with this module's
per-path tracer (:func:`trace_path`); a path of weight 0 is not traced (outcome
``UNWEIGHTED``, counted with the unbinned paths).
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels import trace
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, RIGHT, next_surface
from vcavity.kernels.scaffold import (ABSORBED, DEGENERATE, EXITED, TRUNCATED, UNWEIGHTED, groove_frame,
                                      sample_groove, to_world)
from vcavity.rng import next_uniform

#: The walk's name (:mod:`vcavity.kernels.registry`), its tally planes (path counts, then
#: ``Σ q`` and ``Σ q^2`` per order and cell) and statistics columns (the loop's five, the
#: zero-weight paths among the unbinned, then the weight absorbed, truncated and degenerate,
#: in units of ``1/Q``).
NAME = "paper"
DESCRIPTION = "the V-groove walk started on a facet, each path weighted by its lit projected area"
TALLIES = ("counts", "weights", "squares")
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned", "absorbed_weight", "truncated_weight",
         "degenerate_weight")
WEIGHTED = True


#: Every registered distribution can be walked, and nothing is shared by a direction's
#: paths: the V-groove walk's.
walkable = trace.walkable
prepare_direction = trace.prepare_direction


@njit(cache=True, inline="always")
def trace_path(kind, state, ix, iy, iz, setup, params, dist_kind, facet_kind, facet_variant, facet_data,
               max_bounces, weight_scale):
    """Trace one path started on a uniform point of a groove's facet, weighted by its lit area.

    Returns ``(state, outcome, bounces, wx, wy, wz, q)`` as the V-groove walk's
    :func:`vcavity.kernels.trace.trace_path`, with ``q = floor(w Q + u)`` the path's integer weight (``Q =
    weight_scale``) and the exit direction normalised; a back-facing or shadowed start has
    weight 0 and is not traced (``UNWEIGHTED``). ``setup`` is not used.
    """
    state, tan_m, cos_phi, sin_phi = sample_groove(state, dist_kind, params)
    cos_t, sin_t, dx, dy, dz = groove_frame(tan_m, cos_phi, sin_phi, ix, iy, iz)
    state, u0 = next_uniform(state)
    if u0 < 0.5:  # a uniform point of the left facet, x in (-1, 0]
        surface = LEFT
        x = -2.0 * u0
        nx = sin_t
        cos_in = -(dz + tan_m * dx) * cos_t
    else:  # of the right facet, x in [0, 1)
        surface = RIGHT
        x = 2.0 * u0 - 1.0
        nx = -sin_t
        cos_in = -(dz - tan_m * dx) * cos_t
    lit = cos_in > 0.0
    if lit:  # visible from the light: toward i the segment leaves the groove
        toward, _x = next_surface(surface, x, -dx, -dz, tan_m)
        lit = toward == OPENING
    if not lit:
        return state, UNWEIGHTED, 0, 0.0, 0.0, 0.0, np.int64(0)
    state, u_round = next_uniform(state)
    q = np.int64(math.floor(cos_in / (iz * cos_t) * weight_scale + u_round))
    k = 0
    while True:
        k += 1
        state, event, dx, dy, dz = facets.event(facet_kind, facet_variant, state, dx, dy, dz, cos_in, nx, cos_t,
                                                facet_data)
        if event == FACET_ABSORBED:
            return state, ABSORBED, k, 0.0, 0.0, 0.0, q
        surface, x = next_surface(surface, x, dx, dz, tan_m)
        if surface == OPENING:
            break
        if surface == NO_HIT:
            return state, DEGENERATE, k, 0.0, 0.0, 0.0, q
        if k == max_bounces:
            return state, TRUNCATED, k, 0.0, 0.0, 0.0, q
        if surface == LEFT:
            nx = sin_t
            cos_in = -(dz + tan_m * dx) * cos_t
        else:
            nx = -sin_t
            cos_in = -(dz - tan_m * dx) * cos_t
    wx, wy = to_world(dx, dy, cos_phi, sin_phi)
    inv = 1.0 / math.sqrt(wx * wx + wy * wy + dz * dz)
    return state, EXITED, k, wx * inv, wy * inv, dz * inv, q



__all__ = ["NAME", "STATS", "TALLIES", "WEIGHTED", "prepare_direction", "trace_path", "walkable"]
