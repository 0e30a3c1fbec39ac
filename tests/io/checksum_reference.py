"""The per-point checksum of a sweep file, written out from docs/sweeps.md with h5py and
hashlib only (not vcavity.io.sweep_checksum): SHA-256 of the prefix and the point's
values of each sealed variable, in the documented order, as little-endian bytes of the
stored type, C order; the first 8 bytes of the digest as a little-endian uint64."""

from __future__ import annotations

import hashlib

import h5py
import numpy as np

PREFIX = b"vcavity-sweep-point-v1\n"
# docs/sweeps.md, "Writing, interrupting, resuming": the sealed variables, in this order
SEALED = ("brdf", "brdf_stderr", "counts", "albedo", "absorbed", "truncated", "degenerate", "paths",
          "unbinned_paths", "folded", "relative_error", "target_reached", "max_bounces_seen", "seed")


def _text(value):
    return value.decode() if isinstance(value, bytes) else str(value)


def checksums(h5) -> np.ndarray:
    """The checksum of every point of the open sweep file ``h5`` (uint64, point axes' shape),
    computed from the values it holds, whatever its ``done`` flags say."""
    grid = _text(h5.attrs["grid_axes"]).split()
    points = _text(h5.attrs["point_axes"]).split()
    at = [grid.index(name) for name in points]
    shape = tuple(h5[name].shape[0] for name in points)
    values = {name: h5[name][()] for name in SEALED}
    out = np.zeros(shape, dtype=np.uint64)
    for index in np.ndindex(shape):
        digest = hashlib.sha256(PREFIX)
        for name in SEALED:
            if name == "seed":  # on the point axes only
                part = values[name][index]
            else:  # grid axes first, then order and cell: fix the point axes among them
                where = [slice(None)] * values[name].ndim
                for position, i in zip(at, index):
                    where[position] = i
                part = values[name][tuple(where)]
            part = np.asarray(part)
            digest.update(part.astype(part.dtype.newbyteorder("<")).tobytes(order="C"))
        out[index] = int.from_bytes(digest.digest()[:8], "little")
    return out


def reseal(path) -> None:
    """Store, for every point marked done, the checksum of the values the file holds now
    (as a hostile edit that also fixes the checksums would)."""
    with h5py.File(path, "r+") as h5:
        sums = checksums(h5)
        h5["checksum"][...] = np.where(h5["done"][()] == 1, sums, np.uint64(0))
