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
chunking.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.arrays import borrowed
from vcavity.sensor.binning import bin_block
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, RIGHT, next_surface
from vcavity.kernels.scaffold import (ABSORBED, DEGENERATE, EXITED, TRUNCATED, block_start, build_kernel,
                                      exit_buffers, groove_frame, sample_groove, to_world)
from vcavity.rng import next_uniform

#: The walk's name (:mod:`vcavity.kernels.walks`), its tally planes and statistics columns.
NAME = "paper"
TALLIES = ("weights", "squares", "counts")
STATS = ("absorbed_weight", "truncated_weight", "degenerate_weight", "max_bounces", "unbinned", "absorbed",
         "truncated", "degenerate")

# per-slot statistics (the positions of STATS): weight sums (in units of 1/Q) and path counts
PAPER_ABSORBED = 0
PAPER_TRUNCATED = 1
PAPER_DEGENERATE = 2
PAPER_MAX_BOUNCES = 3
PAPER_ZERO_WEIGHT = 4  # paths with w = 0: back-facing or shadowed start, not traced ("unbinned")
PAPER_ABSORBED_PATHS = 5
PAPER_TRUNCATED_PATHS = 6
PAPER_DEGENERATE_PATHS = 7
N_PAPER_STATS = 8


def arguments(call) -> tuple:
    """The kernel's arguments for a :class:`vcavity.kernels.walks.WalkCall` (signature: :func:`get_paper_kernel`)."""
    return (call.incident, call.direction_key, call.first_block, call.n_blocks, call.n_paths, call.params,
            call.facet_data, call.max_bounces, call.max_order, call.resolution, call.n_slots, call.weight_scale)


def get_paper_kernel(dist_kind: int, facet_kind: int, facet_variant: int):
    """The kernel of the paper-estimator walk for one scene (built once per process).

    Signature::

        kernel(incident, direction_key, first_block, n_blocks, n_paths, params, facet_data,
               max_bounces, max_order, resolution, n_slots, weight_scale)
            -> (weights[n_slots, max_order + 1, n_cells], squares[...], counts[...],
                stats[n_slots, N_PAPER_STATS]), all int64

    ``weights`` holds Σ q and ``squares`` Σ q^2 of the paths of each order slot (slot 0:
    beyond max_order) and cell, ``counts`` the number of those paths; ``q = floor(w Q + u)``
    with ``Q = weight_scale``. Blocks and slots as in :func:`vcavity.kernels.trace.get_kernel`.
    """
    return build_kernel("paper_kernel", _make_paper_kernel, dist_kind, facet_kind, facet_variant, 3, N_PAPER_STATS, 3)


get_kernel = get_paper_kernel


def _make_paper_kernel(DIST, FACET, VARIANT, SOURCE_TAG):
    """The Python walk of one slot of one scene, for :func:`vcavity.kernels.scaffold.build_kernel`."""

    def walk(slot, incident, direction_key, first_block, n_blocks, n_paths, params, facet_data,
             max_bounces, max_order, resolution, n_slots, weight_scale, weights, squares, counts, stats, exits,
             exit_ints):
        # weights, squares, counts [max_order + 1, n_cells] and stats [N_PAPER_STATS]: this
        # slot's rows, zeroed; exits, exit_ints: its scratch rows (exit_buffers; row 2: q)
        _ = SOURCE_TAG  # part of the cache key; see vcavity.kernels.scaffold.SOURCE_TAG
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        exit_x, exit_y, exit_z, exit_row, exit_cell = exit_buffers(exits, exit_ints)
        exit_q = exit_ints[2]
        walk_params = borrowed(params)  # no reference counting per path (_numba.arrays)
        walk_data = borrowed(facet_data)
        for b in range(slot, n_blocks, n_slots):
            state, n_here = block_start(direction_key, first_block, b, n_paths)
            n_exits = np.int64(0)  # not a literal 0: Numba would also compile bin_block for Literal[int](0)
            for _ in range(n_here):
                state, tan_m, cos_phi, sin_phi = sample_groove(state, DIST, walk_params)
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
                    stats[PAPER_ZERO_WEIGHT] += 1
                    continue
                state, u_round = next_uniform(state)
                q = np.int64(math.floor(cos_in / (iz * cos_t) * weight_scale + u_round))
                k = 0
                fate = EXITED
                while True:
                    k += 1
                    state, event, dx, dy, dz = facets.event(FACET, VARIANT, state, dx, dy, dz, cos_in,
                                                            nx, cos_t, walk_data)
                    if event == FACET_ABSORBED:
                        fate = ABSORBED
                        break
                    surface, x = next_surface(surface, x, dx, dz, tan_m)
                    if surface == OPENING:
                        break
                    if surface == NO_HIT:
                        fate = DEGENERATE
                        break
                    if k == max_bounces:
                        fate = TRUNCATED
                        break
                    if surface == LEFT:
                        nx = sin_t
                        cos_in = -(dz + tan_m * dx) * cos_t
                    else:
                        nx = -sin_t
                        cos_in = -(dz - tan_m * dx) * cos_t
                if k > stats[PAPER_MAX_BOUNCES]:  # not max(): one integer overload less to compile
                    stats[PAPER_MAX_BOUNCES] = k
                if fate == EXITED:
                    wx, wy = to_world(dx, dy, cos_phi, sin_phi)
                    inv = 1.0 / math.sqrt(wx * wx + wy * wy + dz * dz)
                    exit_x[n_exits] = wx * inv
                    exit_y[n_exits] = wy * inv
                    exit_z[n_exits] = dz * inv
                    exit_row[n_exits] = k if k <= max_order else 0
                    exit_q[n_exits] = q
                    n_exits += 1
                else:  # the PAPER_* columns are in the order of the outcome codes
                    stats[PAPER_ABSORBED + fate - ABSORBED] += q
                    stats[PAPER_ABSORBED_PATHS + fate - ABSORBED] += 1
            bin_block(exit_x, exit_y, exit_z, n_exits, resolution, exit_cell)
            for j in range(n_exits):
                order = exit_row[j]
                cell = exit_cell[j]
                q = exit_q[j]
                weights[order, cell] += q
                squares[order, cell] += q * q
                counts[order, cell] += 1

    return walk
