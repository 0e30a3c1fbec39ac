"""What the two walks share (:mod:`vcavity.kernels.trace`, :mod:`vcavity.kernels.paper`).

- :func:`build_kernel`: one compiled variant per scene, built once per process and cached
  on disk under a name of its own, its thread slots run at once on Python threads
  (:class:`SlotKernel`, :func:`run_slots`);
- :data:`SOURCE_TAG`: the hash of every source file the kernels are built from
  (:func:`source_files`), which each kernel closes over so that Numba's cache notices
  edits to inlined code;
- per slot, :func:`exit_buffers` (a block's exits, binned together after its walks) and
  :func:`block_start` (a block's random stream and path count);
- per path, :func:`sample_groove` and :func:`groove_frame` (the sampled groove and the
  incident direction in its frame), and :func:`to_world` (an exit direction back in the
  world frame);
- the outcome codes of one path.

The jitted helpers are ``inline="always"``: each kernel compiles them into its own body,
with the same operations in the same order as when they were written out there.
"""

from __future__ import annotations

import concurrent.futures
import hashlib
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from vcavity._numba.jit import njit
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, block_key, next_uniform

# outcome codes of one path
EXITED = 0
ABSORBED = 1
TRUNCATED = 2
DEGENERATE = 3


def source_files() -> list[Path]:
    """Every source file the kernels are built from, in the order :data:`SOURCE_TAG` hashes them.

    The kernels' own folder, the facet models and distributions they inline, the Numba
    plumbing (``njit``, the registries' dispatch), the exit binning and the random streams.

    Returns
    -------
    list of pathlib.Path
    """
    root = Path(__file__).resolve().parent.parent
    files = [path for sub in ("kernels", "facet", "microfacet", "_numba", "rng") for path in sorted((root / sub).glob("*.py"))]
    return files + [root / "sensor/binning.py"]


def _source_tag() -> int:
    """Hash of every source file the kernels inline (:func:`source_files`).

    Numba's on-disk cache only notices edits to the file of the cached function itself,
    not to the functions it inlines from other modules. The kernel closes over this tag,
    and closure values are part of Numba's cache key, so editing any of these files
    recompiles the kernel instead of silently running stale code.
    """
    digest = hashlib.blake2b(digest_size=8)
    for path in source_files():
        digest.update(path.read_bytes())
    return int.from_bytes(digest.digest(), "little") >> 1


#: Hash of the kernels' sources (:func:`_source_tag`); a closure value of every kernel.
SOURCE_TAG = _source_tag()

_KERNELS: dict[tuple[str, int, int, int], "SlotKernel"] = {}

# positions of the arguments every walk takes first (trace, smith and paper kernels)
_N_BLOCKS, _MAX_ORDER, _RESOLUTION, _N_SLOTS = 3, 8, 9, 10


class SlotKernel:
    """One scene's compiled walk, its thread slots run at once on Python threads.

    Called as the kernels' documented signature, ``kernel(incident, direction_key,
    first_block, n_blocks, n_paths, params, facet_data, max_bounces, max_order,
    resolution, n_slots, *rest)``; returns the walk's ``n_tallies`` tallies
    ``[n_slots, max_order + 1, resolution**2]`` and its statistics ``[n_slots, n_stats]``,
    all int64 and zeroed here. Slot ``s`` traces blocks ``s, s + n_slots, ...`` by calling
    :attr:`walk` with ``s``, the arguments, and its rows of :meth:`outputs`; the walk is
    compiled with ``nogil=True``, so the slots run in parallel (:func:`run_slots`: slot 0
    in the calling thread, the others on a pool of threads). Threads rather than Numba's
    ``prange`` in a ``parallel=True`` kernel: the parallel loop's passes and lowering were
    a third of each variant's cold compile, and the walks are as fast (docs/performance.md,
    "Compile time: slots on Python threads"). Results do not depend on ``n_slots`` (blocks
    own their streams; counts are integers).

    Parameters
    ----------
    walk : numba dispatcher
        The jitted walk of one slot.
    n_tallies, n_stats, n_exit_ints : int
        Tallies the walk fills, its statistics columns, and the rows of its int64 exit
        buffer (:func:`exit_buffers`).
    """

    def __init__(self, walk, n_tallies: int, n_stats: int, n_exit_ints: int):
        self.walk = walk
        self.n_tallies = n_tallies
        self.n_stats = n_stats
        self.n_exit_ints = n_exit_ints

    def __call__(self, *args):
        outputs = self.outputs(int(args[_N_SLOTS]), int(args[_MAX_ORDER]), int(args[_RESOLUTION]))

        def walk_slot(slot):
            self.walk(slot, *args, *self.slot_rows(outputs, slot))

        # a slot without blocks leaves its rows zero: no thread for it (slot 0 always runs,
        # so that a call without blocks compiles the walk, as Simulation.compile expects)
        busy = max(1, min(int(args[_N_SLOTS]), int(args[_N_BLOCKS])))
        run_slots(walk_slot, busy, compiled=bool(self.walk.overloads))
        return outputs[:-2]

    def outputs(self, n_slots: int, max_order: int, resolution: int) -> tuple:
        """The arrays of one call: the tallies and statistics (zeroed), then the exit buffers."""
        tally_shape = (n_slots, max_order + 1, resolution * resolution)
        return (*[np.zeros(tally_shape, np.int64) for _ in range(self.n_tallies)],
                np.zeros((n_slots, self.n_stats), np.int64),
                np.empty((n_slots, 3, BLOCK_SIZE)), np.empty((n_slots, self.n_exit_ints, BLOCK_SIZE), np.int64))

    @staticmethod
    def slot_rows(outputs: tuple, slot: int) -> tuple:
        """Slot ``slot``'s rows of :meth:`outputs`: the walk's last arguments."""
        return tuple(array[slot] for array in outputs)


# The slots' threads, kept between calls: a pool made and shut down per call cost ~150 us a
# call, kept ~85 us (waking a sleeping thread and hearing back; 2 slots, docs/performance.md).
# Threads are made as slots need them (up to _MAX_SLOT_THREADS) and sleep when idle; a
# forked child starts a pool of its own (the parent's threads do not exist there).
_MAX_SLOT_THREADS = 1024
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


def _slot_pool() -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max_workers=_MAX_SLOT_THREADS, thread_name_prefix="vcavity-slot")
        return _pool


def _forget_pool() -> None:
    global _pool, _pool_lock
    _pool, _pool_lock = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool)


def run_slots(walk_slot, n_slots: int, compiled: bool) -> None:
    """``walk_slot(s)`` for ``s`` in ``range(n_slots)``, concurrently; slot 0 in this thread.

    The other slots run on a pool of threads kept between calls. A walk not yet compiled
    (or loaded from the cache) in this process runs slot 0 first, alone: the compile
    happens once, in the calling thread, where the compile notice and Ctrl-C work as for
    any call (:class:`vcavity.simulate.warmup.CompileNotice`). Returns when every slot
    has; an exception in one is raised here after the others end.
    """
    if n_slots < 1:
        return
    if n_slots == 1:
        walk_slot(0)
        return
    if not compiled:
        walk_slot(0)
    futures = [_slot_pool().submit(walk_slot, slot) for slot in range(1, n_slots)]
    try:
        if compiled:
            walk_slot(0)
    finally:
        # every slot ends before this returns or raises: no walk outlives its call's arrays
        concurrent.futures.wait(futures)
    for future in futures:
        future.result()


def build_kernel(prefix: str, make, dist_kind: int, facet_kind: int, facet_variant: int,
                 n_tallies: int, n_stats: int, n_exit_ints: int = 2) -> SlotKernel:
    """The compiled walk ``make`` builds for one scene, built once per process.

    Parameters
    ----------
    prefix : str
        Name of the walk (``"kernel"``, ``"paper_kernel"``); with the three integers it
        names the variant.
    make : callable
        ``make(DIST, FACET, VARIANT, SOURCE_TAG)`` returns the Python walk of one slot, a
        closure over those four integers only: closures over plain ints are cacheable,
        closures over dispatchers are not, and the tag makes source edits part of the
        cache key.
    dist_kind, facet_kind, facet_variant : int
        The distribution and facet model (positions in their registries) and the
        facet's compiled variant.
    n_tallies, n_stats, n_exit_ints : int
        What the walk fills, and the rows of its int64 exit buffer (:class:`SlotKernel`).

    Returns
    -------
    SlotKernel
        Over ``njit(cache=True, nogil=True)`` of the walk.
    """
    key = (int(dist_kind), int(facet_kind), int(facet_variant))
    if (prefix, *key) in _KERNELS:
        return _KERNELS[(prefix, *key)]
    DIST, FACET, VARIANT = key
    walk = make(DIST, FACET, VARIANT, SOURCE_TAG)
    # Every variant gets its own name: Numba names the cache files and the compiled
    # symbols after __qualname__ (plus a per-process counter), so variants compiled in
    # different processes under one name collided when loaded together ("descr is NULL").
    walk.__qualname__ = walk.__name__ = f"{prefix}_d{DIST}_f{FACET}_v{VARIANT}"
    kernel = SlotKernel(njit(cache=True, nogil=True)(walk), n_tallies, n_stats, n_exit_ints)
    _KERNELS[(prefix, *key)] = kernel
    return kernel


@njit(cache=True, inline="always")
def exit_buffers(exits, exit_ints):
    """A block's exits, gathered during its walks and binned together after them.

    Binned a block at a time, the binning's loop (sqrt, division, atan polynomial) runs in
    SIMD lanes, ~12 ns a path less than binning each exit as it leaves (docs/performance.md).
    The slot's buffers come from :class:`SlotKernel` (allocated in Python: an ``np.empty``
    in the walk would compile NumPy's allocation for each dtype into every variant).

    Parameters
    ----------
    exits : ndarray, shape (3, BLOCK_SIZE)
    exit_ints : ndarray of int64, shape (n_exit_ints >= 2, BLOCK_SIZE)

    Returns
    -------
    exit_x, exit_y, exit_z : ndarray, shape (BLOCK_SIZE,)
        World-frame exit directions (rows of ``exits``).
    exit_row, exit_cell : ndarray of int64, shape (BLOCK_SIZE,)
        Order slot of each exit, and the cell the binning writes (rows 0 and 1 of
        ``exit_ints``; a walk may use further rows for its own).
    """
    return exits[0], exits[1], exits[2], exit_ints[0], exit_ints[1]


@njit(cache=True, inline="always")
def block_start(direction_key, first_block, b, n_paths):
    """Stream state and path count of block ``first_block + b`` of a direction.

    Parameters
    ----------
    direction_key : uint64
        Key of the direction's streams (:func:`vcavity.rng.direction_key`).
    first_block, b : int
        First block of the call and position of this one in it.
    n_paths : int
        Paths of the direction: its last block is short when this is not a multiple of
        ``BLOCK_SIZE``.

    Returns
    -------
    state : uint64
        The block's own stream (:func:`vcavity.rng.block_key`), so results do not depend
        on how blocks are split over calls or slots.
    n_here : int
        Paths in the block.
    """
    block = first_block + b
    n_here = n_paths - block * BLOCK_SIZE
    if n_here > BLOCK_SIZE:  # not min(): one integer overload less to compile per variant
        n_here = BLOCK_SIZE
    return block_key(direction_key, block), n_here


@njit(cache=True, inline="always")
def sample_groove(state, dist_kind, params):
    """Advance ``state``; return (state, tan theta_m, cos phi_m, sin phi_m).

    The groove normal has pdf D(m)(m.n) (physics.md sec. 2), sampled from a uniform
    point of the unit disk by the distribution's trig-free ``sample_disk``.
    """
    while True:
        state, ua = next_uniform(state)
        state, ub = next_uniform(state)
        a = 2.0 * ua - 1.0
        b = 2.0 * ub - 1.0
        s = a * a + b * b
        if 0.0 < s < 1.0:
            tan_m, cos_phi, sin_phi = distributions.sample_disk(dist_kind, a, b, s, params)
            return state, tan_m, cos_phi, sin_phi


@njit(cache=True, inline="always")
def groove_frame(tan_m, cos_phi, sin_phi, ix, iy, iz):
    """The groove's wall cosine and sine, and ``d = -i`` in the groove frame.

    The groove frame has ``x' = (cos phi, sin phi, 0)`` across the groove and
    ``y' = (-sin phi, cos phi, 0)`` along it.

    Parameters
    ----------
    tan_m, cos_phi, sin_phi : float
        The sampled groove (:func:`sample_groove`).
    ix, iy, iz : float
        Unit vector toward the light.

    Returns
    -------
    cos_t, sin_t : float
        ``cos theta_m`` and ``sin theta_m`` of the walls (finite for any finite tangent).
    dx, dy, dz : float
        Direction of travel of the incoming light in the groove frame.
    """
    if tan_m < 1e150:
        cos_t = 1.0 / math.sqrt(1.0 + tan_m * tan_m)
        sin_t = tan_m * cos_t
    else:  # tan^2 would overflow
        cos_t = 1.0 / tan_m
        sin_t = 1.0
    dx = -(ix * cos_phi + iy * sin_phi)
    dy = -(iy * cos_phi - ix * sin_phi)
    dz = -iz
    return cos_t, sin_t, dx, dy, dz


@njit(cache=True, inline="always")
def to_world(dx, dy, cos_phi, sin_phi):
    """World-frame ``(x, y)`` of a groove-frame direction (its ``z`` is the same in both)."""
    wx = dx * cos_phi - dy * sin_phi
    wy = dx * sin_phi + dy * cos_phi
    return wx, wy


__all__ = ["EXITED", "ABSORBED", "TRUNCATED", "DEGENERATE", "SOURCE_TAG", "source_files", "build_kernel", "SlotKernel", "run_slots", "exit_buffers",
           "block_start", "sample_groove", "groove_frame", "to_world"]
