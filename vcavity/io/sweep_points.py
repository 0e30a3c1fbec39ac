"""Committing one finished point of a sweep file in place (docs/sweeps.md, "Writing, interrupting, resuming").

A sweep file is created whole (:func:`vcavity.io.sweep_table.write_sweep`) with every
dataset contiguous and written, so each value of each point has a fixed byte offset in
the file and HDF5's metadata (superblock, object headers, heaps) never changes again.
:class:`PointWriter` then commits a finished point with plain ``os.pwrite`` into those
bytes, never through HDF5:

1. the point's values, every variable but ``checksum`` and ``done``; ``fsync``;
2. its ``checksum`` (:mod:`vcavity.io.sweep_checksum`), then ``done = 1``; ``fsync``.

A kill -9, a power loss or a full disk at any moment leaves a valid HDF5 file (its
metadata was never open for writing) in which the point is not done: before step 2 its
``done`` is still 0; within step 2 the checksum, written before the flag and after the
values reached the disk, cannot match values that did not (the reader then reads it as
not done). Each commit costs the point's own bytes and two fsyncs, whatever the number
of points. Why not through h5py: an HDF5 file open for writing that is killed can be
left with damaged metadata, and HDF5 writing to a full disk gave tracebacks and crashes
(issue 20); here a full disk is an ordinary ``OSError``.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from vcavity.io.checks import attribute_value
from vcavity.io.sweep_checksum import point_slice
from vcavity.io.sweep_table import FORMAT_NAME, VARIABLES, SweepData

#: Written last, in this order, once the values are on disk: the point's commit.
SEAL = ("checksum", "done")


class NotInPlace(ValueError):
    """The file cannot take points in place; the message says why. ``convertible`` is True
    when it is this sweep in the layout of files written before in-place commits (writing
    it whole once converts it), False when it is another file or sweep."""

    def __init__(self, message: str, convertible: bool = False):
        super().__init__(message)
        self.convertible = convertible


class _Layout:
    """Where the values of each point of one variable lie in the file: ``offset`` of the
    dataset, ``runs`` of consecutive elements of a point relative to its first."""

    def __init__(self, name: str, offset: int, shape: tuple[int, ...], dims: tuple[str, ...],
                 point_axes: tuple[str, ...]):
        self.name, self.offset, self.dims = name, offset, dims
        self.dtype = np.dtype(VARIABLES[name][1]).newbyteorder("<")
        strides = np.cumprod((1,) + shape[:0:-1])[::-1]  # C order, in elements
        self.point_strides = {d: int(strides[k]) for k, d in enumerate(dims) if d in point_axes}
        other = [(int(strides[k]), shape[k]) for k, d in enumerate(dims) if d not in point_axes]
        relative = np.zeros(1, dtype=np.int64)
        for stride, size in other:  # element offsets of a point's values in C order of their axes
            relative = (relative[:, None] + stride * np.arange(size)[None, :]).ravel()
        breaks = np.flatnonzero(np.diff(relative) != 1) + 1
        self.starts = np.concatenate(([0], breaks))  # runs: index into the point's values
        self.ends = np.concatenate((breaks, [relative.size]))
        self.relative = relative[self.starts]

    def pieces(self, data: SweepData, point_axes, index):
        """``(file offset, bytes)`` of every run of point ``index``."""
        values = np.asarray(data.data[self.name][point_slice(self.dims, point_axes, index)], dtype=self.dtype)
        flat = values.reshape(-1).tobytes()
        first = sum(self.point_strides[d] * i for d, i in zip(point_axes, index))
        size = self.dtype.itemsize
        return [(self.offset + (first + int(rel)) * size, flat[start * size:end * size])
                for rel, start, end in zip(self.relative, self.starts, self.ends)]


def write_at(fd: int, data: bytes, offset: int) -> None:
    """Write all of ``data`` at ``offset`` of ``fd`` (a full disk is an ``OSError``)."""
    view = memoryview(data)
    while view:
        written = os.pwrite(fd, view, offset)
        if written <= 0:
            raise OSError(f"wrote nothing at offset {offset}")
        view, offset = view[written:], offset + written


class PointWriter:
    """Commits finished points of ``data`` into the sweep file at ``path``, in place.

    Parameters
    ----------
    path : path
        A sweep file written by :func:`~vcavity.io.sweep_table.write_sweep` for ``data``'s
        sweep (same ``spec_digest``, ``overrides`` and shape).
    data : SweepData
        The sweep in memory; every point the file marks done must be done here too (the
        file holds nothing newer than what was read from it).

    Raises
    ------
    NotInPlace
        The file is not such a file (nothing was written to it).
    OSError
        The file cannot be opened for writing, or clearing the ``done`` flag of a point
        whose checksum failed could not be written.
    """

    def __init__(self, path, data: SweepData):
        self.path, self.data = Path(path), data
        self._fd = os.open(self.path, os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC)
        try:
            self._layouts = self._check()
            self._clear_rejected()
        except BaseException:
            os.close(self._fd)
            raise

    def _check(self) -> dict:
        """Read the layout through the open descriptor (the file that will be written)."""
        data = self.data
        with os.fdopen(os.dup(self._fd), "rb") as stream, h5py.File(stream, "r") as h5:
            for key in ("format", "spec_digest", "overrides"):
                stored, wanted = h5.attrs.get(key), (FORMAT_NAME if key == "format" else data.attrs.get(key))
                stored = stored.decode() if isinstance(stored, bytes) else stored
                if stored != wanted:
                    raise NotInPlace(f"its attribute {key} is {attribute_value(stored)!r}, not "
                                     f"{attribute_value(wanted)!r} (another file or sweep)")
            layouts = {}
            end = os.fstat(self._fd).st_size
            for name in VARIABLES:
                if name not in h5:
                    raise NotInPlace(f"it has no dataset {name} (written before points were committed in place)",
                                     convertible=True)
                dataset = h5[name]
                shape, dims = data.data[name].shape, data.dims(name)
                plist = dataset.id.get_create_plist()
                offset = dataset.id.get_offset()
                size = int(np.prod(shape)) * np.dtype(VARIABLES[name][1]).itemsize
                if (dataset.shape != shape or plist.get_layout() != h5py.h5d.CONTIGUOUS or plist.get_nfilters()
                        or dataset.dtype.str != np.dtype(VARIABLES[name][1]).newbyteorder("<").str
                        or offset is None or dataset.id.get_storage_size() != size or offset + size > end):
                    raise NotInPlace(f"its dataset {name} is not stored contiguously with shape {shape}, "
                                     "as written since points are committed in place", convertible=True)
                layouts[name] = _Layout(name, offset, shape, dims, data.point_axes)
            stored_done = h5["done"][()]
        if np.any((stored_done == 1) & (data.data["done"] != 1)):
            self._rejected = np.argwhere((stored_done == 1) & (data.data["done"] != 1))
        else:
            self._rejected = np.zeros((0, len(data.point_axes)), dtype=np.int64)
        if np.any((data.data["done"] == 1) & (stored_done != 1)):
            raise NotInPlace("it marks points not done that were done when it was read (it changed meanwhile)")
        return layouts

    def _clear_rejected(self) -> None:
        """``done = 0`` in the file where the reader rejected the point's checksum, before any
        of its bytes change (the point is run again)."""
        if len(self._rejected):
            for index in self._rejected:
                for offset, piece in self._layouts["done"].pieces(self.data, self.data.point_axes,
                                                                  tuple(int(i) for i in index)):
                    write_at(self._fd, piece, offset)  # the value in memory: 0
            os.fsync(self._fd)

    def commit(self, index: tuple[int, ...]) -> None:
        """Write point ``index`` (done and recorded in :attr:`data`) into the file, sealed.

        Raises
        ------
        OSError
            A write or fsync failed (a full disk): the point is not done in the file, every
            point committed before is intact.
        """
        data, index = self.data, tuple(int(i) for i in index)
        data.data["checksum"][index] = data.checksum(index)
        for name, layout in self._layouts.items():
            if name not in SEAL:
                for offset, piece in layout.pieces(data, data.point_axes, index):
                    write_at(self._fd, piece, offset)
        os.fsync(self._fd)  # the values are on disk before the checksum and flag that vouch for them
        for name in SEAL:
            for offset, piece in self._layouts[name].pieces(data, data.point_axes, index):
                write_at(self._fd, piece, offset)
        os.fsync(self._fd)

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


__all__ = ["NotInPlace", "PointWriter", "SEAL", "write_at"]
