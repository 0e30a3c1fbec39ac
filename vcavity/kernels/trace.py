"""The V-groove random walk (physics.md sec. 5), specialised per scene.

``get_kernel(dist_kind, facet_mode)`` returns a jitted, parallel kernel closed over two
integer constants, so each compiled variant contains only the code its scene needs:
a mirror never draws for Fresnel, ``kd = 0`` never samples the body, ``eta = 1`` never
evaluates Fresnel. Variants are compiled on first use and cached on disk
(``cache=True``; closures over plain ints are cacheable, closures over dispatchers are
not, hence the integer switches below, which LLVM folds away).

The kernel is analog: every path has weight 1, so per-cell results are integer counts
and merging per-thread histograms is exact in any order.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from vcavity.facet.fresnel import fresnel_dielectric
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, next_surface
from vcavity.microfacet import beckmann, gaussian, ggx, phong
from vcavity.rng import BLOCK_SIZE, block_key, next_uniform
from vcavity.sensor import direction_to_cell

# facet modes: which facet events can happen (physics.md sec. 4, limits)
MIRROR = 0  # F = 1: always reflect
DIELECTRIC = 1  # kd = 0: reflect with probability F, else absorbed by the body
LAMBERTIAN = 2  # eta = 1: F = 0, re-emit with probability kd, cosine-weighted
INTERFACED_LAMBERTIAN = 3  # full IL facet
FACET_MODE_NAMES = ("mirror", "specular dielectric", "lambertian", "interfaced lambertian")

# per-slot statistics columns
STAT_ABSORBED = 0
STAT_TRUNCATED = 1
STAT_DEGENERATE = 2
STAT_MAX_BOUNCES = 3
N_STATS = 4


@njit(cache=True, inline="always")
def _sample_groove(dist_kind, u1, u2, params):
    """(tan theta_m, cos phi_m, sin phi_m) with pdf D(m)(m.n) (physics.md sec. 2)."""
    if dist_kind == beckmann.KIND:
        return beckmann.sample(u1, u2, params)
    elif dist_kind == ggx.KIND:
        return ggx.sample(u1, u2, params)
    elif dist_kind == phong.KIND:
        return phong.sample(u1, u2, params)
    return gaussian.sample(u1, u2, params)


@njit(cache=True, inline="always")
def _emerge(state, facet_mode, eta, nx, nz):
    """Direction leaving the IL body through a facet of normal (nx, 0, nz).

    pdf proportional to T(w.m)(w.m) (physics.md sec. 4): a cosine-weighted direction
    (uniform point (a, b) in the unit disk, mu = sqrt(1 - a^2 - b^2)), accepted with
    probability T(mu) = 1 - F(mu) when the interface is a dielectric (eta > 1).
    Tangents: t1 = (nz, 0, -nx), t2 = (0, 1, 0).
    """
    while True:
        state, ua = next_uniform(state)
        state, ub = next_uniform(state)
        a = 2.0 * ua - 1.0
        b = 2.0 * ub - 1.0
        rho2 = a * a + b * b
        if rho2 >= 1.0:
            continue
        mu = math.sqrt(1.0 - rho2)
        if facet_mode == INTERFACED_LAMBERTIAN:
            state, ut = next_uniform(state)
            if ut >= 1.0 - fresnel_dielectric(mu, eta):
                continue
        return state, a * nz + mu * nx, b, mu * nz - a * nx


@njit(cache=True, inline="always")
def _trace_path(state, ix, iy, iz, params, dist_kind, facet_mode, eta, emergence_prob,
                max_bounces, max_order, resolution, counts, stats):
    """Trace one path; add it to ``counts`` (order slot, cell) or ``stats``; return the stream state."""
    state, u1 = next_uniform(state)
    state, u2 = next_uniform(state)
    tan_m, cos_phi, sin_phi = _sample_groove(dist_kind, u1, u2, params)
    cos_t = 1.0 / math.hypot(1.0, tan_m)
    sin_t = tan_m * cos_t
    # d = -i in the groove frame (x' = (cos phi, sin phi, 0), y' = (-sin phi, cos phi, 0))
    dx = -(ix * cos_phi + iy * sin_phi)
    dy = -(iy * cos_phi - ix * sin_phi)
    dz = -iz
    state, u0 = next_uniform(state)
    x = 2.0 * u0 - 1.0  # uniform entry point on the opening
    surface = OPENING
    k = 0
    while True:
        surface, x = next_surface(surface, x, dx, dz, tan_m)
        if surface == OPENING:
            break
        if surface == NO_HIT:
            stats[STAT_DEGENERATE] += 1
            return state
        if k == max_bounces:
            stats[STAT_TRUNCATED] += 1
            stats[STAT_MAX_BOUNCES] = max(stats[STAT_MAX_BOUNCES], k)
            return state
        k += 1
        # facet normal (nx, 0, nz); cos_in = -(d.n) is written with the same rate the
        # geometry used, so it is > 0 whenever the facet was hit.
        if surface == LEFT:
            nx = sin_t
            cos_in = -(dz + tan_m * dx) * cos_t
        else:
            nx = -sin_t
            cos_in = -(dz - tan_m * dx) * cos_t
        nz = cos_t
        if facet_mode == MIRROR:
            reflect = True
        elif facet_mode == LAMBERTIAN:
            reflect = False
        else:
            state, u = next_uniform(state)
            reflect = u < fresnel_dielectric(cos_in, eta)
        if reflect:
            dx += 2.0 * cos_in * nx
            dz += 2.0 * cos_in * nz
            continue
        if facet_mode == DIELECTRIC:
            stats[STAT_ABSORBED] += 1
            stats[STAT_MAX_BOUNCES] = max(stats[STAT_MAX_BOUNCES], k)
            return state
        # enters the body; re-emerges with probability a (== 1.0 exactly when kd == 1)
        state, u = next_uniform(state)
        if u >= emergence_prob:
            stats[STAT_ABSORBED] += 1
            stats[STAT_MAX_BOUNCES] = max(stats[STAT_MAX_BOUNCES], k)
            return state
        state, dx, dy, dz = _emerge(state, facet_mode, eta, nx, nz)
    # exit through the opening: back to the world frame, bin, count
    wx = dx * cos_phi - dy * sin_phi
    wy = dx * sin_phi + dy * cos_phi
    inv = 1.0 / math.sqrt(wx * wx + wy * wy + dz * dz)
    cell = direction_to_cell(wx * inv, wy * inv, dz * inv, resolution)
    slot = k if k <= max_order else 0
    counts[slot, cell] += 1
    stats[STAT_MAX_BOUNCES] = max(stats[STAT_MAX_BOUNCES], k)
    return state


_KERNELS: dict[tuple[int, int], object] = {}


def get_kernel(dist_kind: int, facet_mode: int):
    """The jitted walk for one distribution kind and facet mode (built once per process).

    The returned function has the signature::

        kernel(incident, direction_key, first_block, n_blocks, n_paths, params, eta,
               emergence_prob, max_bounces, max_order, resolution, n_slots)
            -> (counts[n_slots, max_order + 1, resolution**2] int64,
                stats[n_slots, N_STATS] int64)

    ``incident`` is the unit vector ``i`` (toward the light). Blocks
    ``first_block .. first_block + n_blocks - 1`` of ``BLOCK_SIZE`` paths are traced,
    the last block of the direction being short when ``n_paths`` is not a multiple of
    ``BLOCK_SIZE``. Order slot 0 counts paths with more than ``max_order`` bounces.
    Slot ``s`` traces blocks ``s, s + n_slots, ...``; results do not depend on
    ``n_slots`` because blocks own their random streams and counts are integers.
    """
    key = (int(dist_kind), int(facet_mode))
    if key in _KERNELS:
        return _KERNELS[key]
    DIST = key[0]
    FACET = key[1]

    @njit(cache=True, parallel=True)
    def kernel(incident, direction_key, first_block, n_blocks, n_paths, params, eta,
               emergence_prob, max_bounces, max_order, resolution, n_slots):
        n_cells = resolution * resolution
        counts = np.zeros((n_slots, max_order + 1, n_cells), np.int64)
        stats = np.zeros((n_slots, N_STATS), np.int64)
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        for slot in prange(n_slots):
            slot_counts = counts[slot]
            slot_stats = stats[slot]
            for b in range(slot, n_blocks, n_slots):
                block = first_block + b
                start = block * BLOCK_SIZE
                n_here = min(BLOCK_SIZE, n_paths - start)
                state = block_key(direction_key, block)
                for _ in range(n_here):
                    state = _trace_path(state, ix, iy, iz, params, DIST, FACET, eta,
                                        emergence_prob, max_bounces, max_order, resolution,
                                        slot_counts, slot_stats)
        return counts, stats

    _KERNELS[key] = kernel
    return kernel
