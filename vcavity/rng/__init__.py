"""Counter-based random numbers for the walk.

Every block of paths owns one stream, keyed by a hash of (seed, incident direction,
block index). A block is a fixed unit of paths (``BLOCK_SIZE`` by default) that does not
depend on how the work is split across threads, chunks, checkpoints or workers, so a
table is bitwise identical however the run is scheduled. Numba's global per-thread
generator is never used.

The stream is SplitMix64 (Steele, Lea & Flood 2014): draw ``k`` of a stream with key
``K`` is ``mix64(K + (k + 1) * GOLDEN)``. Keys are themselves ``mix64`` hashes, so two
streams overlap only if their keys differ by a small multiple of ``GOLDEN``: with
2^16 draws per block and 10^6 blocks the chance of any overlap is below 1e-2 per
run, and an overlap of a few draws would not bias a table.
"""

from __future__ import annotations

import struct

import numpy as np

from vcavity._numba.jit import njit

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0  # 2^-53

#: Paths per RNG block. Part of the definition of a run: changing it changes the table.
BLOCK_SIZE = 4096


# mix64 and next_uniform are plain jitted functions, not IR-inlined (inline="always"): a
# kernel calls next_uniform at about ten sites, and Numba's IR inlining re-types each copy
# (the compile time it cost: docs/performance.md, "Figures from the code's comments"); LLVM
# inlines the compiled function all the same, so the walk runs as fast.
@njit(cache=True)
def mix64(z):
    """SplitMix64 finaliser: a bijective 64-bit hash (uint64 -> uint64)."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit(cache=True)
def next_uniform(state):
    """Advance a stream; return ``(new_state, u)`` with ``u`` uniform in [0, 1).

    ``u`` has 53 random bits, so the largest value is ``1 - 2**-53``.
    """
    state = np.uint64(state) + GOLDEN
    return state, np.float64(mix64(state) >> _S11) * _TWO_M53


@njit(cache=True)
def next_bits(state):
    """Advance a stream; return ``(new_state, bits)``, the draw's 64 random bits (uint64).

    The same draw as :func:`next_uniform`, whose ``u`` is the top 53 of these bits: for
    samplers that use disjoint bits of one draw for several choices
    (:mod:`vcavity.rng.ziggurat`).
    """
    state = np.uint64(state) + GOLDEN
    return state, mix64(state)


@njit(cache=True)
def block_key(direction_key, block):
    """Stream key of one block of one incident direction (uint64)."""
    return mix64(direction_key ^ mix64(np.uint64(block) + GOLDEN))


def _float_bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def _mix64_py(z: int) -> int:
    mask = (1 << 64) - 1
    z &= mask
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
    return z ^ (z >> 31)


def direction_key(seed: int, theta_i: float, phi_i: float) -> np.uint64:
    """Key of the streams of one incident direction of one run.

    Hashes the seed and the exact float64 bits of ``theta_i`` and ``phi_i`` (radians),
    so adding or reordering directions in a run does not change the others' tables.
    """
    mask = (1 << 64) - 1
    h = _mix64_py((int(seed) & mask) ^ 0x5EED5EED5EED5EED)
    h = _mix64_py(h ^ _float_bits(theta_i))
    h = _mix64_py((h + 0x9E3779B97F4A7C15) & mask ^ _float_bits(phi_i))
    return np.uint64(h)
