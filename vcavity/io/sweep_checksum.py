"""The checksum of one point of a sweep file (docs/sweeps.md, "Writing, interrupting, resuming").

Each finished point is committed in place: its values first, then its checksum and its
``done`` flag (:mod:`vcavity.io.sweep_points`). A reader trusts ``done = 1`` only when the
stored checksum equals the one recomputed from the values it reads, so a point whose
write was cut short (kill -9, power loss, a full disk), or whose bytes changed since, is
read as not done and ``--resume`` runs it again.

The recipe, for the point at index ``p`` of the point axes::

    h = SHA-256("vcavity-sweep-point-v1\\n")
    for each variable of SEALED, in that order:
        h.update(the variable's values at p (every index of the other axes), C order,
                 as little-endian bytes of its stored type)
    checksum = first 8 bytes of h.digest(), read as a little-endian uint64

Timings (``compute_time_s``), ``done`` and the checksum itself are not part of it, so an
interrupted and resumed sweep stores the same checksums as an uninterrupted one.
NumPy and hashlib only: reading a sweep compiles nothing.
"""

from __future__ import annotations

import hashlib

import numpy as np

PREFIX = b"vcavity-sweep-point-v1\n"
#: Not part of a point's checksum: timings, the flag it guards and the checksum itself.
UNSEALED = ("compute_time_s", "done", "checksum")


def sealed(names) -> tuple[str, ...]:
    """The variables a checksum covers, in their order in ``names`` (the file's variables)."""
    return tuple(name for name in names if name not in UNSEALED)


def point_slice(dims: tuple[str, ...], point_axes: tuple[str, ...], index: tuple[int, ...]) -> tuple:
    """Index into a variable on ``dims`` selecting the point ``index`` (of ``point_axes``)."""
    where = dict(zip(point_axes, index))
    return tuple(where[d] if d in where else slice(None) for d in dims)


def point_checksum(arrays: dict, dims: dict, point_axes: tuple[str, ...], index: tuple[int, ...]) -> np.uint64:
    """The checksum of point ``index`` (the module doc's recipe).

    Parameters
    ----------
    arrays : dict
        Variable name -> array (with the stored dtype), in file order; only the names
        :func:`sealed` keeps enter.
    dims : dict
        Variable name -> its dimension names.
    point_axes : tuple of str
        The axes that index a point.
    index : tuple of int
        The point's position on ``point_axes``.

    Returns
    -------
    numpy.uint64
    """
    digest = hashlib.sha256(PREFIX)
    for name in sealed(arrays):
        values = arrays[name][point_slice(dims[name], point_axes, index)]
        # C order, little-endian: a view (no copy) where the point's values are one block already
        digest.update(np.ascontiguousarray(values, dtype=arrays[name].dtype.newbyteorder("<")).data)
    return np.uint64(int.from_bytes(digest.digest()[:8], "little"))


def verified(arrays: dict, dims: dict, point_axes: tuple[str, ...], done: np.ndarray,
             stored: np.ndarray) -> np.ndarray:
    """Which points marked done (``done == 1``) hold the checksum ``stored`` for them.

    Returns
    -------
    numpy.ndarray of bool
        Shape of ``done``: True where the point is done and its checksum matches.
    """
    good = np.zeros(done.shape, dtype=bool)
    for index in np.ndindex(done.shape):  # (): a sweep of one point (only incidence axes)
        if done[index] == 1:
            good[index] = point_checksum(arrays, dims, point_axes, index) == stored[index]
    return good


__all__ = ["PREFIX", "UNSEALED", "point_checksum", "point_slice", "sealed", "verified"]
