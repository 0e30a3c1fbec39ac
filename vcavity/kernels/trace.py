"""The V-groove random walk (physics.md sec. 5), specialised per scene.

``get_kernel(dist_kind, facet_kind, facet_variant)`` returns a kernel whose jitted walk
(one thread slot's blocks, run on a Python thread per slot:
:class:`vcavity.kernels.scaffold.SlotKernel`) is closed over three integer constants: the distribution and the facet model (positions in
their registries, :mod:`vcavity.microfacet.registry`, :mod:`vcavity.facet.registry`) and
the facet's compiled variant. Each variant contains only the code its scene needs: the
registries pick the distribution's trig-free groove sampler and the facet's event at
compile time, so a mirror never draws for Fresnel, ``kd = 0`` never samples the body and
``eta = 1`` never evaluates Fresnel. Variants are compiled on first use and cached on disk
(``cache=True``; closures over plain ints are cacheable, closures over dispatchers are
not, hence integer constants). The path walk, the sampler and the event are each compiled
apart and inlined by LLVM (:func:`vcavity._numba.dispatch.apart`); the walk hands them
reference-count-free views of its arrays (:func:`vcavity._numba.arrays.borrowed`).

The kernel is analog: every path has weight 1, so per-cell results are integer counts
and merging per-thread histograms is exact in any order.

Specialisations that are *not* compiled variants (so the number of variants stays at one
per distribution x facet variant, :func:`variants`): isotropic roughness takes a
stretch-free branch inside the distributions' ``sample_disk`` (a loop-invariant test, free
when predicted); ``max_bounces = 1`` (f1 only) ends a path at its second wall hit before
any event; ``first_binned_order = 2`` skips binning the first-order exits. Exits are
binned a block at a time (:func:`vcavity.sensor.binning.bin_block`, vectorised), not one by one.
Throughput and compile times: docs/performance.md.
"""

from __future__ import annotations

import numpy as np

from vcavity._numba.arrays import borrowed
from vcavity._numba.dispatch import apart
from vcavity._numba.jit import njit
from vcavity.sensor.binning import bin_block
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, enter, leave
from vcavity.kernels.scaffold import (ABSORBED, DEGENERATE, EXITED, TRUNCATED, block_start, build_kernel,
                                      exit_buffers, groove_frame, sample_groove, to_world)
from vcavity.microfacet import registry as distributions
from vcavity.rng import next_uniform

#: The walk's name (:mod:`vcavity.kernels.walks`), its tally planes and statistics columns.
NAME = "v-cavity"
TALLIES = ("counts",)
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned")

# per-slot statistics columns (the positions of STATS)
STAT_ABSORBED = 0
STAT_TRUNCATED = 1
STAT_DEGENERATE = 2
STAT_MAX_BOUNCES = 3
STAT_UNBINNED = 4  # exits of an order below first_binned_order: counted, not binned
N_STATS = 5


@njit(cache=True, inline="always")
def _trace_path(state, ix, iy, iz, params, dist_kind, facet_kind, facet_variant, facet_data,
                max_bounces):
    """Trace one path from the light into a sampled groove until it leaves or ends.

    Returns ``(state, outcome, bounces, wx, wy, wz)``: the advanced stream state, one of
    ``EXITED / ABSORBED / TRUNCATED / DEGENERATE``, the number of facet events, and the
    world-frame exit direction (unit to rounding, valid when ``outcome == EXITED``; the
    caller bins it, or not). Nothing is written to memory here, so threads share no
    cache lines in the hot loop.
    """
    state, tan_m, cos_phi, sin_phi = sample_groove(state, dist_kind, params)
    cos_t, sin_t, dx, dy, dz = groove_frame(tan_m, cos_phi, sin_phi, ix, iy, iz)
    state, u0 = next_uniform(state)
    x = 2.0 * u0 - 1.0  # uniform entry point on the opening
    surface, x = enter(x, dx, dz, tan_m)  # always a wall: the segment from the opening
    k = 0
    while True:
        if k > 0:  # the segments after a bounce (the first one is enter's)
            surface, x = leave(surface, x, dx, dz, tan_m)
        if surface == OPENING:
            break
        if surface == NO_HIT:
            return state, DEGENERATE, k, 0.0, 0.0, 0.0
        if k == max_bounces:  # max_bounces = 1 (f1 only): stops here, before a 2nd event
            return state, TRUNCATED, k, 0.0, 0.0, 0.0
        k += 1
        # wall normal (side sin t, 0, cos t), the side selected without a branch (left and
        # right are equally likely); cos_in = -(d.n) is written with the same rate the
        # geometry used, so it is > 0 whenever the wall was hit.
        side = 1.0 if surface == LEFT else -1.0
        cos_in = -(dz + side * (tan_m * dx)) * cos_t
        state, fate, dx, dy, dz = facets.event(facet_kind, facet_variant, state, dx, dy, dz, cos_in,
                                               side * sin_t, cos_t, facet_data)
        if fate == FACET_ABSORBED:
            return state, ABSORBED, k, 0.0, 0.0, 0.0
    # exit through the opening: back to the world frame. Not normalised: reflections and
    # re-emissions keep |d| = 1 to rounding (a few ulp), and the binning tolerates that
    # (binning.bin_block); the sqrt and division cost ~5 ns a path.
    wx, wy = to_world(dx, dy, cos_phi, sin_phi)
    return state, EXITED, k, wx, wy, dz


#: The path walk compiled apart from the kernel, once per variant (its kinds are the
#: kernel's constants), and inlined by LLVM: 0.9 s of CPU less per variant's cold compile
#: than Numba inlining it (docs/performance.md, "Compile time: compiled apart").
trace_path = apart(_trace_path, __name__)


def variants() -> list[tuple[str, str, str]]:
    """Every kernel variant :func:`get_kernel` can build, as (distribution, facet, facet variant) names.

    One per registered distribution and facet variant (5 x (1 + 3) = 20 today); each is
    compiled on first use (2-3 s of CPU, docs/performance.md) and then loaded from
    Numba's disk cache. The list follows the registries, so a new distribution or facet
    model adds its variants here without edits.

    Returns
    -------
    list of (str, str, str)
        In registry order. ``get_kernel(distributions.kind_of(d), facets.kind_of(f),
        facets.get(f).VARIANTS.index(v))`` builds the variant ``(d, f, v)``.
    """
    return [(dist.NAME, facet.NAME, name)
            for dist in distributions.MODULES for facet in facets.MODULES for name in facet.VARIANTS]


def arguments(call) -> tuple:
    """The kernel's arguments for a :class:`vcavity.kernels.walks.WalkCall` (signature: :func:`get_kernel`)."""
    return (call.incident, call.direction_key, call.first_block, call.n_blocks, call.n_paths, call.params,
            call.facet_data, call.max_bounces, call.max_order, call.resolution, call.n_slots, call.first_binned_order)


def get_kernel(dist_kind: int, facet_kind: int, facet_variant: int):
    """The kernel for one distribution, facet model and facet variant (built once per process).

    The returned kernel (a :class:`vcavity.kernels.scaffold.SlotKernel`) is called as::

        kernel(incident, direction_key, first_block, n_blocks, n_paths, params, facet_data,
               max_bounces, max_order, resolution, n_slots, first_binned_order)
            -> (counts[n_slots, max_order + 1, resolution**2] int64,
                stats[n_slots, N_STATS] int64)

    ``incident`` is the unit vector ``i`` (toward the light); ``params`` the
    distribution's parameter array and ``facet_data`` the facet's prepared data (see
    the registries). Blocks ``first_block .. first_block + n_blocks - 1`` of
    ``BLOCK_SIZE`` paths are traced, the last block of the direction being short when
    ``n_paths`` is not a multiple of ``BLOCK_SIZE``. Order slot 0 counts paths with more
    than ``max_order`` bounces. Slot ``s`` traces blocks ``s, s + n_slots, ...`` on a
    thread of its own; results do not depend on ``n_slots`` because blocks own their
    random streams and counts are integers. Exits after fewer than ``first_binned_order`` bounces are not binned, only
    counted (``stats[:, STAT_UNBINNED]``): the exact-f1 estimator passes 2 and skips the
    binning of the ~90 % of paths that leave after one bounce; their counts row stays 0.
    """
    return build_kernel("kernel", _make_kernel, dist_kind, facet_kind, facet_variant, 1, N_STATS)


def _make_kernel(DIST, FACET, VARIANT, SOURCE_TAG):
    """The Python walk of one slot of one scene, for :func:`vcavity.kernels.scaffold.build_kernel`."""

    def walk(slot, incident, direction_key, first_block, n_blocks, n_paths, params, facet_data,
             max_bounces, max_order, resolution, n_slots, first_binned_order, counts, stats, exits,
             exit_ints):
        # counts [max_order + 1, resolution**2] and stats [N_STATS]: this slot's rows, zeroed;
        # exits, exit_ints: its scratch rows (exit_buffers)
        _ = SOURCE_TAG  # part of the cache key; see vcavity.kernels.scaffold.SOURCE_TAG
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        absorbed = 0
        truncated = 0
        degenerate = 0
        deepest = 0
        unbinned = 0
        exit_x, exit_y, exit_z, exit_row, exit_cell = exit_buffers(exits, exit_ints)
        walk_params = borrowed(params)  # no reference counting per path (_numba.arrays)
        walk_data = borrowed(facet_data)
        for b in range(slot, n_blocks, n_slots):
            state, n_here = block_start(direction_key, first_block, b, n_paths)
            n_exits = np.int64(0)  # not a literal 0: Numba would also compile bin_block for Literal[int](0)
            for _ in range(n_here):
                state, outcome, k, wx, wy, wz = trace_path(
                    state, ix, iy, iz, walk_params, DIST, FACET, VARIANT, walk_data, max_bounces)
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
                elif outcome == ABSORBED:
                    absorbed += 1
                elif outcome == TRUNCATED:
                    truncated += 1
                else:
                    degenerate += 1
            bin_block(exit_x, exit_y, exit_z, n_exits, resolution, exit_cell)
            for j in range(n_exits):
                counts[exit_row[j], exit_cell[j]] += 1
        stats[STAT_ABSORBED] = absorbed
        stats[STAT_TRUNCATED] = truncated
        stats[STAT_DEGENERATE] = degenerate
        stats[STAT_MAX_BOUNCES] = deepest
        stats[STAT_UNBINNED] = unbinned

    return walk
