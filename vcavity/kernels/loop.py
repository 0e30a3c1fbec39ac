"""The one slot loop every walk runs: block streams, the per-path tracer, exit buffers, binning, tallies.

A compiled walk (:func:`build`) is this loop closed over six integer constants: the walk
(its position in :mod:`vcavity.kernels.registry`), whether its paths are weighted, the
distribution, the facet model, the facet's variant and :data:`SOURCE_TAG
<vcavity.kernels.scaffold.SOURCE_TAG>`. Closures over plain ints are cacheable (closures
over jitted functions are not: their pickles change per process), and the registries'
dispatch resolves each constant at compile time, so a variant holds its walk's tracer,
its distribution's sampler and its facet's event and nothing else; the weighted walk's
sums are dead code in the others.

One thread slot traces blocks ``slot, slot + n_slots, ...`` of ``BLOCK_SIZE`` paths, each
block from its own random stream (:func:`vcavity.kernels.scaffold.block_start`), so the
results depend on neither the slots nor the chunking. A block's exits are gathered and
binned together after its paths (``bin_block``, vectorised), then added to the slot's
tally planes; the statistics columns are written once at the end. :class:`SlotKernel`
runs the slots of one call at once on Python threads (:mod:`vcavity.kernels.slots`); the
call is a named structure (:class:`vcavity.kernels.walks.WalkCall`) whose fields
:func:`arguments` lays out in the loop's order, in this module only.
"""

from __future__ import annotations

import numpy as np

from vcavity._numba.arrays import borrowed
from vcavity._numba.jit import njit
from vcavity.kernels import registry as walks
from vcavity.kernels.scaffold import (ABSORBED, DEGENERATE, EXITED, SOURCE_TAG, TRUNCATED, UNWEIGHTED, block_start,
                                      exit_buffers)
from vcavity.kernels.slots import run_slots
from vcavity.rng import BLOCK_SIZE
from vcavity.sensor.binning import bin_block

#: Statistics columns the loop writes, in order (a weighted walk's first eight).
COLUMNS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned", "absorbed_weight", "truncated_weight",
           "degenerate_weight")
# the loop counts a lost path in column outcome - ABSORBED (and its weight 5 columns on)
assert [COLUMNS.index(name) for name in ("absorbed", "truncated", "degenerate")] == [
    ABSORBED - ABSORBED, TRUNCATED - ABSORBED, DEGENERATE - ABSORBED]
assert COLUMNS.index("absorbed_weight") == 5


def arguments(call) -> tuple:
    """The loop's arguments after the slot, from a :class:`vcavity.kernels.walks.WalkCall`."""
    return (call.incident, call.direction_key, call.first_block, call.n_blocks, call.n_paths, call.params,
            call.facet_data, call.max_bounces, call.max_order, call.resolution, call.n_slots,
            call.first_binned_order, call.setup, call.weight_scale)


def _make_loop(WALK, WEIGHTED, DIST, FACET, VARIANT, SOURCE_TAG):
    """The Python loop of one slot of one walk and scene (module doc), for :func:`build`."""

    def walk(slot, incident, direction_key, first_block, n_blocks, n_paths, params, facet_data, max_bounces,
             max_order, resolution, n_slots, first_binned_order, setup, weight_scale, counts, sums, stats, exits,
             exit_ints):
        # counts [max_order + 1, resolution**2], a weighted walk's sums [2, max_order + 1,
        # resolution**2] (weights, squares) and stats [n_stats]: this slot's rows, zeroed;
        # exits, exit_ints: its scratch rows (exit_buffers; row 2 of exit_ints: the weights)
        _ = SOURCE_TAG  # part of the cache key; see vcavity.kernels.scaffold.SOURCE_TAG
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        walk_params = borrowed(params)  # no reference counting per path (_numba.arrays)
        walk_data = borrowed(facet_data)
        deepest = 0
        unbinned = 0
        exit_x, exit_y, exit_z, exit_row, exit_cell = exit_buffers(exits, exit_ints)
        exit_q = exit_ints[2]
        for b in range(slot, n_blocks, n_slots):
            state, n_here = block_start(direction_key, first_block, b, n_paths)
            n_exits = np.int64(0)  # not a literal 0: Numba would also compile bin_block for Literal[int](0)
            for _ in range(n_here):
                state, outcome, k, wx, wy, wz, q = walks.trace_path(
                    WALK, state, ix, iy, iz, setup, walk_params, DIST, FACET, VARIANT, walk_data, max_bounces,
                    weight_scale)
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
                        if WEIGHTED:
                            exit_q[n_exits] = q
                        n_exits += 1
                elif outcome == UNWEIGHTED:  # a path of weight 0, not traced
                    unbinned += 1
                else:  # absorbed, truncated, degenerate: columns 0-2 (5-7: their weight), in the codes' order
                    stats[outcome - ABSORBED] += 1
                    if WEIGHTED:
                        stats[5 + outcome - ABSORBED] += q
            bin_block(exit_x, exit_y, exit_z, n_exits, resolution, exit_cell)
            for j in range(n_exits):
                counts[exit_row[j], exit_cell[j]] += 1
            if WEIGHTED:
                for j in range(n_exits):
                    q = exit_q[j]
                    sums[0, exit_row[j], exit_cell[j]] += q
                    sums[1, exit_row[j], exit_cell[j]] += q * q
        stats[3] = deepest
        stats[4] = unbinned

    return walk


class SlotKernel:
    """One scene's compiled walk, its thread slots run at once on Python threads.

    Called with a :class:`vcavity.kernels.walks.WalkCall`; returns the tally planes
    ``[n_slots, max_order + 1, resolution**2]`` (``counts``, and a weighted walk's
    ``weights``, ``squares``) and the statistics ``[n_slots, n_stats]``, all int64 and
    zeroed here. Slot ``s`` traces blocks ``s, s + n_slots, ...`` by calling :attr:`walk`
    with ``s``, the call's :func:`arguments` and its rows of :meth:`outputs`; the walk is
    compiled with ``nogil=True``, so the slots run in parallel (:func:`run_slots`: slot 0
    in the calling thread, the others on a pool of threads). Results do not depend on
    ``n_slots`` (blocks own their streams; counts are integers).

    Parameters
    ----------
    walk : numba dispatcher
        The jitted loop of one slot (:func:`build`).
    n_tallies, n_stats : int
        The walk's tally planes and statistics columns.
    """

    def __init__(self, walk, n_tallies: int, n_stats: int):
        self.walk = walk
        self.n_tallies = n_tallies
        self.n_stats = n_stats

    def __call__(self, call) -> tuple:
        outputs = self.outputs(call.n_slots, call.max_order, call.resolution)
        args = arguments(call)

        def walk_slot(slot):
            self.walk(slot, *args, *self.slot_rows(outputs, slot))

        # a slot without blocks leaves its rows zero: no thread for it (slot 0 always runs,
        # so that a call without blocks compiles the walk, as Simulation.compile expects)
        busy = max(1, min(int(call.n_slots), int(call.n_blocks)))
        run_slots(walk_slot, busy, compiled=bool(self.walk.overloads))
        counts, sums, stats = outputs[:3]
        return (counts, *[sums[:, plane] for plane in range(self.n_tallies - 1)], stats)

    def outputs(self, n_slots: int, max_order: int, resolution: int) -> tuple:
        """The arrays of one call: three tally planes (those the walk has not: one cell, never
        written), the statistics (zeroed), then the exit buffers."""
        cells = (max_order + 1, resolution * resolution)
        sums = (n_slots, 2, *cells) if self.n_tallies > 1 else (n_slots, 1, 1, 1)  # a weighted walk's
        return (np.zeros((n_slots, *cells), np.int64), np.zeros(sums, np.int64), np.zeros((n_slots, self.n_stats), np.int64),
                np.empty((n_slots, 3, BLOCK_SIZE)), np.empty((n_slots, 3, BLOCK_SIZE), np.int64))

    @staticmethod
    def slot_rows(outputs: tuple, slot: int) -> tuple:
        """Slot ``slot``'s rows of :meth:`outputs`: the walk's last arguments."""
        return tuple(array[slot] for array in outputs)


_KERNELS: dict[tuple[int, int, int, int], SlotKernel] = {}


def build(walk_kind: int, dist_kind: int, facet_kind: int, facet_variant: int) -> SlotKernel:
    """The compiled walk ``walk_kind`` for one scene, built once per process.

    Parameters
    ----------
    walk_kind : int
        The walk's position in :mod:`vcavity.kernels.registry`.
    dist_kind, facet_kind, facet_variant : int
        The distribution and facet model (positions in their registries) and the facet's
        compiled variant.

    Returns
    -------
    SlotKernel
        Over ``njit(cache=True, nogil=True)`` of the loop, cached on disk under a name of its own.
    """
    key = (int(walk_kind), int(dist_kind), int(facet_kind), int(facet_variant))
    if key in _KERNELS:
        return _KERNELS[key]
    module = walks.MODULES[walks.REGISTRY.check_kind(walk_kind, "build")]
    if module.STATS != COLUMNS[:len(module.STATS)] or len(module.STATS) != (8 if module.WEIGHTED else 5):
        raise ValueError(f"walk {module.NAME!r}: STATS must be the loop's columns {COLUMNS[:5]} (weighted: all "
                         f"{len(COLUMNS)}), got {module.STATS}")
    WALK, DIST, FACET, VARIANT = key
    loop = _make_loop(WALK, int(bool(module.WEIGHTED)), DIST, FACET, VARIANT, SOURCE_TAG)
    # Every variant gets its own name: Numba names the cache files and the compiled
    # symbols after __qualname__ (plus a per-process counter), so variants compiled in
    # different processes under one name collided when loaded together ("descr is NULL").
    loop.__qualname__ = loop.__name__ = f"{module.__name__.rsplit('.', 1)[1]}_d{DIST}_f{FACET}_v{VARIANT}"
    kernel = SlotKernel(njit(cache=True, nogil=True)(loop), len(module.TALLIES), len(module.STATS))
    _KERNELS[key] = kernel
    return kernel


__all__ = ["COLUMNS", "SlotKernel", "arguments", "build"]
