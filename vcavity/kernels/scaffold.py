"""What the walks share (:mod:`vcavity.kernels.trace`, :mod:`vcavity.kernels.smith`,
:mod:`vcavity.kernels.paper`, and their one slot loop, :mod:`vcavity.kernels.loop`).

- :data:`SOURCE_TAG`: the hash of every source file the kernels are built from
  (:func:`source_files`), which each kernel closes over so that Numba's cache notices
  edits to inlined code;
- per slot, :func:`exit_buffers` (a block's exits, binned together after its walks) and
  :func:`block_start` (a block's random stream and path count);
- per path, :func:`sample_groove` and :func:`groove_frame` (the sampled groove and the
  incident direction in its frame), and :func:`to_world` (an exit direction back in the
  world frame);
- the outcome codes of one path.

The jitted helpers are ``inline="always"``: each walk compiles them into its own body,
with the same operations in the same order as when they were written out there.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

from vcavity._numba.jit import njit
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, block_key, next_uniform

# outcome codes of one path (the order of the first statistics columns, absorbed first)
EXITED = 0
ABSORBED = 1
TRUNCATED = 2
DEGENERATE = 3
UNWEIGHTED = 4  # a weighted walk's path of weight 0: not traced (counted as unbinned)


def source_files() -> list[Path]:
    """Every source file the kernels are built from, in the order :data:`SOURCE_TAG` hashes them.

    The kernels' own folder, the facet models and distributions they inline, the Numba
    plumbing (``njit``, the registries' dispatch), the exit binning and the random streams.
    Not the CUDA loop (``kernels/cuda_loop.py``): no CPU kernel inlines it, so editing it
    must not recompile them, and its own kernel is cached under its own file.

    Returns
    -------
    list of pathlib.Path
    """
    root = Path(__file__).resolve().parent.parent
    files = [path for sub in ("kernels", "facet", "microfacet", "_numba", "rng")
             for path in sorted((root / sub).glob("*.py")) if path != root / "kernels" / "cuda_loop.py"]
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

@njit(cache=True, inline="always")
def exit_buffers(exits, exit_ints):
    """A block's exits, gathered during its walks and binned together after them.

    Binned a block at a time, the binning's loop (sqrt, division, atan polynomial) runs in
    SIMD lanes, faster than binning each exit as it leaves (docs/performance.md, "Figures
    from the code's comments").
    The slot's buffers come from :class:`vcavity.kernels.loop.SlotKernel` (allocated in Python: an ``np.empty``
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


__all__ = ["EXITED", "ABSORBED", "TRUNCATED", "DEGENERATE", "UNWEIGHTED", "SOURCE_TAG", "source_files", "exit_buffers",
           "block_start", "sample_groove", "groove_frame", "to_world"]
