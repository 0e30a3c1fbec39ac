"""The V-groove random walk (physics.md sec. 5): one path traced from the light through a sampled groove.

The walk of a scene is the one slot loop of :mod:`vcavity.kernels.loop` with this
module's per-path tracer, :func:`trace_path`; its variants are closed over three integer
constants, the distribution and the facet model (positions in their registries,
:mod:`vcavity.microfacet.registry`, :mod:`vcavity.facet.registry`) and the facet's
compiled variant. Each variant contains only the code its scene needs: the registries pick
the distribution's trig-free groove sampler and the facet's event at compile time, so a
mirror never draws for Fresnel, ``kd = 0`` never samples the body and ``eta = 1`` never
evaluates Fresnel. The path walk (:func:`trace_path`, dispatched by
:mod:`vcavity.kernels.registry`), the sampler and the event are each compiled apart and
inlined by LLVM (docs/performance.md, "Compile time: compiled apart").

The walk is analog: every path has weight 1, so per-cell results are integer counts and
merging per-thread histograms is exact in any order.

Specialisations that are *not* compiled variants (so the number of variants stays at one
per distribution x facet variant, :func:`variants`): isotropic roughness takes a
stretch-free branch inside the distributions' ``sample_disk`` (a loop-invariant test, free
when predicted); ``max_bounces = 1`` (f1 only) ends a path at its second wall hit before
any event; ``first_binned_order = 2`` skips binning the first-order exits.
Throughput and compile times: docs/performance.md.
"""

from __future__ import annotations

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet import registry as facets
from vcavity.facet.common import ABSORBED as FACET_ABSORBED
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, enter, leave
from vcavity.kernels.scaffold import ABSORBED, DEGENERATE, EXITED, TRUNCATED, groove_frame, sample_groove, to_world
from vcavity.microfacet import registry as distributions
from vcavity.rng import next_uniform

#: The walk's name (:mod:`vcavity.kernels.registry`), its tally planes and statistics
#: columns (the loop's first five: paths absorbed, truncated, degenerate, the deepest path's
#: bounces, exits counted but not binned); weight-1 paths.
NAME = "v-cavity"
DESCRIPTION = "the V-groove walk: paths enter the groove through a uniform point of its opening"
TALLIES = ("counts",)
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned")
WEIGHTED = False


def walkable(distribution: str) -> None:
    """None: every registered distribution can be walked."""
    return None


def prepare_direction(ix, iy, iz, params, dist_kind):
    """Nothing to compute once per direction: 0."""
    return 0.0


@njit(cache=True, inline="always")
def trace_path(kind, state, ix, iy, iz, setup, params, dist_kind, facet_kind, facet_variant, facet_data,
               max_bounces, weight_scale):
    """Trace one path from the light into a sampled groove until it leaves or ends.

    Returns ``(state, outcome, bounces, wx, wy, wz, q)``: the advanced stream state, one of
    ``EXITED / ABSORBED / TRUNCATED / DEGENERATE``, the number of facet events, the
    world-frame exit direction (unit to rounding, valid when ``outcome == EXITED``; the
    caller bins it, or not) and the weight (0: weight-1 paths carry none). ``setup`` and
    ``weight_scale`` are not used, nor ``kind`` (the registry's signature, :mod:`vcavity.kernels.registry`).
    Nothing is written to memory here, so threads share no cache lines in the hot loop.
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
            return state, DEGENERATE, k, 0.0, 0.0, 0.0, np.int64(0)
        if k == max_bounces:  # max_bounces = 1 (f1 only): stops here, before a 2nd event
            return state, TRUNCATED, k, 0.0, 0.0, 0.0, np.int64(0)
        k += 1
        # wall normal (side sin t, 0, cos t), the side selected without a branch (left and
        # right are equally likely); cos_in = -(d.n) is written with the same rate the
        # geometry used, so it is > 0 whenever the wall was hit.
        side = 1.0 if surface == LEFT else -1.0
        cos_in = -(dz + side * (tan_m * dx)) * cos_t
        state, fate, dx, dy, dz = facets.event(facet_kind, facet_variant, state, dx, dy, dz, cos_in,
                                               side * sin_t, cos_t, facet_data)
        if fate == FACET_ABSORBED:
            return state, ABSORBED, k, 0.0, 0.0, 0.0, np.int64(0)
    # exit through the opening: back to the world frame. Not normalised: reflections and
    # re-emissions keep |d| = 1 to rounding (a few ulp), and the binning tolerates that
    # (binning.bin_block), and the sqrt and division would be paid by every path.
    wx, wy = to_world(dx, dy, cos_phi, sin_phi)
    return state, EXITED, k, wx, wy, dz, np.int64(0)



def variants() -> list[tuple[str, str, str]]:
    """Every scene a walk is compiled for, as (distribution, facet, facet variant) names.

    One per registered distribution and facet variant (5 x (1 + 3) = 20 today); each is
    compiled on first use (docs/performance.md: compile time) and then loaded from
    Numba's disk cache. The list follows the registries, so a new distribution or facet
    model adds its variants here without edits.

    Returns
    -------
    list of (str, str, str)
        In registry order. ``vcavity.kernels.walks.get(walk, distributions.kind_of(d),
        facets.kind_of(f), facets.get(f).VARIANTS.index(v))`` builds a walk of ``(d, f, v)``.
    """
    return [(dist.NAME, facet.NAME, name)
            for dist in distributions.MODULES for facet in facets.MODULES for name in facet.VARIANTS]


__all__ = ["NAME", "STATS", "TALLIES", "WEIGHTED", "prepare_direction", "trace_path", "walkable", "variants"]
