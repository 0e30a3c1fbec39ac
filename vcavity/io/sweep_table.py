"""Sweep files: the tables of a parameter grid in one HDF5 file (docs/sweeps.md).

A sweep file is a netCDF-4 compatible HDF5 file, like a table (docs/hdf5-format.md), whose
leading dimensions are the grid axes of the sweep, named as the ``[sweep]`` keys
(``alpha``, ``eta``, ``theta_i_deg``, ...), each a dimension scale holding its values as
written, with units where physical. After them come the table's ``order`` and ``cell``::

    brdf(alpha, eta, theta_i_deg, order, cell)      counts, brdf_stderr alike
    albedo(alpha, eta, theta_i_deg, order)
    paths(alpha, eta, theta_i_deg)                  absorbed, truncated, ... per direction
    seed(alpha, eta), done(alpha, eta)              per point: one run of one material

so ``xarray.open_dataset(path, engine="h5netcdf")`` gives a labelled dataset with no
custom code. A *point* is one material (a position on every axis but ``theta_i_deg`` and
``phi_i_deg``); it is run as one run over every incident direction of the grid. Values of
points not yet done are NaN (floats) or 0 (integers) with ``done = 0``.

Like the other files of vcavity this module imports h5py and no Numba (``vcavity info``
reads a sweep without compiling anything). A file is created whole and atomically
(:func:`write_sweep`, :func:`vcavity.io.atomic.write_hdf5`) with every dataset contiguous
and allocated, so its HDF5 metadata never changes afterwards; each later point is
committed in place into its own bytes (:mod:`vcavity.io.sweep_points`), sealed by a
per-point ``checksum`` (:mod:`vcavity.io.sweep_checksum`). The reader trusts ``done = 1``
only where the checksum matches (files written before checksums: every ``done``).
"""

from __future__ import annotations

import datetime
import json
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from vcavity._version import __version__ as _VCAVITY_VERSION
from vcavity.io import checks, schema, sweep_checksum
from vcavity.io.atomic import write_hdf5
from vcavity.io.checks import TableFormatError

FORMAT_NAME = "vcavity-sweep"
FORMAT_VERSION = 1
INCIDENCE_AXES = ("theta_i_deg", "phi_i_deg")
#: radians companion (auxiliary coordinate) of each incidence axis
RADIANS = {"theta_i_deg": "theta_i", "phi_i_deg": "phi_i"}

# name -> (shape kind, dtype, units, long_name, description). Kinds: "cell" (grid, order,
# cell), "order" (grid, order), "direction" (grid), "point" (the point axes only).
_SHARED = ("brdf", "brdf_stderr", "counts", "albedo", "absorbed", "truncated", "degenerate",
           "paths", "unbinned_paths", "folded", "relative_error", "target_reached", "max_bounces_seen")
_KIND = {"brdf": "cell", "brdf_stderr": "cell", "counts": "cell", "albedo": "order"}
_DTYPE = {"counts": np.int64, "paths": np.int64, "unbinned_paths": np.int64, "max_bounces_seen": np.int64,
          "folded": np.int8, "target_reached": np.int8}
VARIABLES = {name: (_KIND.get(name, "direction"), _DTYPE.get(name, np.float64), *schema.DATASETS[name][1:])
             for name in _SHARED}
VARIABLES.update({
    "seed": ("point", np.uint64, "1", "seed of the point's run",
             "Seed of the run of this point: first 8 bytes (little-endian) of SHA-256 of the "
             "sweep seed and the point's material (docs/sweeps.md, 'Seeds')"),
    "done": ("point", np.int8, "1", "point finished",
             "1 when every incident direction of this point is traced and stored, else 0 "
             "(its values are then NaN or 0)"),
    "compute_time_s": ("point", np.float64, "s", "tracing time of the point",
                       "Seconds spent tracing this point (not part of the result)"),
    "checksum": ("point", np.uint64, "1", "checksum of the point's values",
                 "First 8 bytes (little-endian) of SHA-256 of the point's values (docs/sweeps.md, "
                 "'Writing, interrupting, resuming'); done = 1 counts only where it matches, else 0"),
})
#: Variables files written before the per-point checksum lack (their done flags are trusted).
OPTIONAL = ("checksum",)
FLAGS = dict(schema.FLAGS, done=((0, 1), "pending done"))
#: variables that record how long things took: they differ between identical sweeps
TIMING = ("compute_time_s",)
CELL_GEOMETRY = ("theta_o", "phi_o", "cell_center", "cell_solid_angle", "cell_projected_solid_angle")
ROOT_DESCRIPTION = ("Monte-Carlo BRDF tables of microfacet V-cavity surfaces over a parameter grid: "
                    "the grid axes are the leading dimensions, then order and cell as in a vcavity "
                    "table. Layout: docs/sweeps.md of vcavity.")


#: A file is not a readable vcavity sweep (one line): the readers share one error.
SweepFormatError = TableFormatError


@dataclass(frozen=True)
class GridAxis:
    """One axis of the grid: its name (the ``[sweep]`` key), values, units, meaning.

    A paired axis (``[sweep.paired.NAME]``, docs/sweeps.md) also has ``paired``: per key
    it sets, ``(key, values, units, long_name)``, stored as a coordinate along the axis.
    """

    name: str
    values: tuple
    units: str | None = "1"
    long_name: str = ""
    paired: tuple = ()

    @property
    def is_text(self) -> bool:
        """Whether the values are names (``distribution``), not numbers."""
        return any(isinstance(v, str) for v in self.values)

    def array(self) -> np.ndarray:
        """The values as stored: float64, or variable-length UTF-8 strings."""
        return _stored(self.values)


def _stored(values) -> np.ndarray:
    """Axis or coordinate values as stored: float64, or variable-length UTF-8 strings (names)."""
    if any(isinstance(v, str) for v in values):
        return np.array(list(values), dtype=h5py.string_dtype())
    return np.array([float(v) for v in values], dtype=np.float64)


@dataclass
class SweepData:
    """Everything a sweep file holds, in memory (see module doc).

    ``axes`` are the grid axes in file order; ``point_axes`` the names of those that index
    a point (all but the incidence axes). ``scalars`` holds the incidence angles that are
    not swept (``{"phi_i_deg": 0.0}``: stored as scalar coordinates). ``data`` maps each
    name of :data:`VARIABLES` to its array, ``cells`` the sensor geometry, ``attrs`` the
    root attributes (spec, digest, seed, ...), ``material`` what every point shares.
    """

    axes: tuple[GridAxis, ...]
    point_axes: tuple[str, ...]
    order: np.ndarray
    cells: dict
    attrs: dict
    material: dict = field(default_factory=dict)
    scalars: dict = field(default_factory=dict)
    data: dict = field(default_factory=dict)
    path: Path | None = None
    #: points the file marks done whose checksum does not match (read as not done)
    rejected: tuple = ()

    @property
    def shape(self) -> tuple[int, ...]:
        """Sizes of the grid axes."""
        return tuple(len(a.values) for a in self.axes)

    @property
    def point_shape(self) -> tuple[int, ...]:
        """Sizes of the point axes."""
        return tuple(len(a.values) for a in self.axes if a.name in self.point_axes)

    def dims(self, name: str) -> tuple[str, ...]:
        """Dimension names of variable ``name``."""
        kind = VARIABLES[name][0]
        grid = tuple(a.name for a in self.axes)
        return {"cell": grid + ("order", "cell"), "order": grid + ("order",), "direction": grid,
                "point": tuple(self.point_axes)}[kind]

    def allocate(self) -> None:
        """Fill :attr:`data` with the arrays of a sweep where nothing is done yet."""
        sizes = {a.name: len(a.values) for a in self.axes}
        sizes.update(order=len(self.order), cell=len(self.cells["theta_o"]))
        for name, (_, dtype, *_rest) in VARIABLES.items():
            shape = tuple(sizes[d] for d in self.dims(name))
            fill = np.nan if dtype == np.float64 else (-1 if name == "target_reached" else 0)
            self.data[name] = np.full(shape, fill, dtype=dtype)

    def n_done(self) -> int:
        """Points finished."""
        return int(np.sum(self.data["done"] == 1))

    def checksum(self, index: tuple[int, ...]) -> np.uint64:
        """The checksum of the values of point ``index`` (:mod:`vcavity.io.sweep_checksum`)."""
        return sweep_checksum.point_checksum(self.data, {n: self.dims(n) for n in self.data}, self.point_axes,
                                             tuple(index))

    def seal(self) -> None:
        """Set ``checksum`` of every done point from its values (0 for the others)."""
        for index in np.ndindex(self.point_shape):
            self.data["checksum"][index] = self.checksum(index) if self.data["done"][index] == 1 else 0

    def reset(self, index: tuple[int, ...]) -> None:
        """Give point ``index`` the values of a point not done (NaN, 0, -1; its seed is kept)."""
        for name, (kind, dtype, *_rest) in VARIABLES.items():
            if name != "seed":
                fill = np.nan if dtype == np.float64 else (-1 if name == "target_reached" else 0)
                self.data[name][sweep_checksum.point_slice(self.dims(name), self.point_axes, tuple(index))] = fill


def _coordinates(sweep: SweepData, dims: tuple[str, ...]) -> str | None:
    """CF ``coordinates`` of a variable on ``dims``: radians of the incidence axes, the
    scalar (not swept) incidence angles, and the cell angles."""
    names = [RADIANS[d] for d in dims if d in RADIANS]
    names += [key for axis in sweep.axes if axis.name in dims for key, *_ in axis.paired]
    if "theta_i_deg" in dims:
        names += [n for key in sweep.scalars for n in (key, RADIANS[key])]
    if "cell" in dims:
        names += ["theta_o", "phi_o"]
    return " ".join(names) or None


def _describe(dataset, units, long_name, description, coordinates=None) -> None:
    if units is not None:
        dataset.attrs["units"] = units
    dataset.attrs["long_name"] = long_name
    dataset.attrs["description"] = description
    if coordinates:
        dataset.attrs["coordinates"] = coordinates


def _fill(h5, sweep: SweepData) -> None:
    """Write every dataset of ``sweep`` into the open file ``h5`` (see module doc)."""
    root = {"format": FORMAT_NAME, "format_version": np.int64(FORMAT_VERSION),
            "description": ROOT_DESCRIPTION, "conventions": schema.CONVENTIONS,
            "vcavity_version": _VCAVITY_VERSION,
            "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "grid_axes": " ".join(a.name for a in sweep.axes), "point_axes": " ".join(sweep.point_axes)}
    root.update(sweep.attrs)
    h5.attrs.update(root)
    for axis in sweep.axes:
        scale = h5.create_dataset(axis.name, data=axis.array(), track_order=True)
        _describe(scale, axis.units, axis.long_name or axis.name,
                  f"Grid axis {axis.name}: the values of [sweep] {axis.name} as written")
        scale.make_scale(axis.name)
        if axis.paired:
            scale.attrs["paired_keys"] = " ".join(key for key, *_ in axis.paired)
    for axis in sweep.axes:  # what a paired axis sets, point by point: coordinates along it
        for key, values, units, long_name in axis.paired:
            coordinate = h5.create_dataset(key, data=_stored(values), track_order=True)
            _describe(coordinate, units, long_name, f"{key} at each point of the paired axis {axis.name} "
                                                    f"([sweep.paired.{axis.name}] {key} as written)")
            coordinate.dims[0].attach_scale(h5[axis.name])
    for name, values in (("order", sweep.order), ("cell", np.arange(len(sweep.cells["theta_o"]))),
                         ("xyz", np.array([b"x", b"y", b"z"], dtype="S1"))):
        scale = h5.create_dataset(name, data=values, track_order=True)
        _describe(scale, *schema.DATASETS[name][1:])
        scale.make_scale(name)
    for axis in sweep.axes:
        if axis.name in RADIANS:
            rad = h5.create_dataset(RADIANS[axis.name], data=np.radians(axis.array()), track_order=True)
            _describe(rad, *schema.DATASETS[RADIANS[axis.name]][1:])
            rad.dims[0].attach_scale(h5[axis.name])
    for key, value in sweep.scalars.items():  # incidence angles that are not swept: 0-d coordinates
        for name, number in ((key, value), (RADIANS[key], np.radians(value))):
            _describe(h5.create_dataset(name, data=np.float64(number)), *schema.DATASETS[name][1:])
    for name, (kind, dtype, units, long_name, description) in VARIABLES.items():
        data = np.asarray(sweep.data[name], dtype=dtype)
        dims = sweep.dims(name)
        # contiguous and written whole now: the bytes of every point have a fixed place in
        # the file, so a point is later committed in place without touching HDF5 metadata
        dataset = h5.create_dataset(name, data=data, track_order=True)
        _describe(dataset, units, long_name, description, _coordinates(sweep, dims))
        if name in FLAGS:
            dataset.attrs["flag_values"] = np.array(FLAGS[name][0], dtype=np.int8)
            dataset.attrs["flag_meanings"] = FLAGS[name][1]
        for position, dim in enumerate(dims):
            dataset.dims[position].attach_scale(h5[dim])
    for name in CELL_GEOMETRY:
        data = np.asarray(sweep.cells[name], dtype=np.float64)
        dataset = h5.create_dataset(name, data=data, track_order=True)
        _describe(dataset, *schema.DATASETS[name][1:])
        dataset.dims[0].attach_scale(h5["cell"])
        if data.ndim == 2:
            dataset.dims[1].attach_scale(h5["xyz"])
    group = h5.create_group("material", track_order=True)
    group.attrs["description"] = "Material parameters every point of the sweep shares"
    for key, value in sweep.material.items():
        group.attrs[key] = value


def write_sweep(path, sweep: SweepData) -> None:
    """Write ``sweep`` whole to ``path`` atomically (temporary file, fsync, rename).

    Every done point is sealed first (:meth:`SweepData.seal`); every dataset is contiguous,
    so later points can be committed in place (:class:`vcavity.io.sweep_points.PointWriter`).

    Raises
    ------
    OSError
        The file could not be written; ``path`` is untouched, no temporary file is left.
    """
    sweep.seal()
    write_hdf5(path, lambda h5: _fill(h5, sweep), track_order=True)


def _text(value):
    return value.decode("utf-8") if isinstance(value, bytes) else value


def is_sweep_file(path) -> bool:
    """Whether ``path`` is an HDF5 file of format ``vcavity-sweep`` (False when unreadable)."""
    try:
        with h5py.File(path, "r") as h5:
            return _text(h5.attrs.get("format")) == FORMAT_NAME
    except (OSError, ValueError):
        return False


def open_sweep(path) -> SweepData:
    """Read a sweep file into memory.

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    SweepFormatError
        Not a readable sweep file of a supported version, or holding values no sweep
        writes (:func:`vcavity.io.checks.check_sweep`); one line naming the dataset. The
        same class as :class:`vcavity.io.checks.TableFormatError`.
    """
    location = Path(path)
    if not location.exists():
        raise FileNotFoundError(f"sweep {str(location)!r}: no such file")
    try:
        with h5py.File(location, "r") as h5:
            return _read(h5, location)
    except OSError as exc:
        raise SweepFormatError(f"sweep {str(location)!r}: not a readable HDF5 file "
                               f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    except (KeyError, ValueError, TypeError, IndexError) as exc:
        if isinstance(exc, SweepFormatError):
            raise
        raise SweepFormatError(f"sweep {str(location)!r}: damaged or incomplete "
                               f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None


def _read(h5, location: Path) -> SweepData:
    attrs = {key: _text(value.item() if isinstance(value, np.generic) else value) for key, value in h5.attrs.items()}
    if attrs.get("format") != FORMAT_NAME:
        raise SweepFormatError(f"sweep {str(location)!r}: not a vcavity sweep file (format = {attrs.get('format')!r})")
    if attrs.get("format_version") != FORMAT_VERSION:
        raise SweepFormatError(f"sweep {str(location)!r}: format_version {attrs.get('format_version')!r} "
                               f"is not readable by this vcavity (reads {FORMAT_VERSION})")
    names = str(attrs["grid_axes"]).split()
    axes = []
    for name in names:
        dataset = h5[name]
        values = [_text(v) for v in dataset[()].tolist()]
        paired = tuple((key, tuple(_text(v) for v in h5[key][()].tolist()), _text(h5[key].attrs.get("units")),
                        _text(h5[key].attrs.get("long_name", key)))
                       for key in _text(dataset.attrs.get("paired_keys", "")).split())
        axes.append(GridAxis(name, tuple(values), _text(dataset.attrs.get("units")),
                             _text(dataset.attrs.get("long_name", name)), paired=paired))
    sweep = SweepData(axes=tuple(axes), point_axes=tuple(str(attrs["point_axes"]).split()),
                      order=h5["order"][()], cells={name: h5[name][()] for name in CELL_GEOMETRY},
                      attrs={k: v for k, v in attrs.items() if k not in ("format", "format_version", "created_utc",
                                                                         "grid_axes", "point_axes", "description",
                                                                         "conventions", "vcavity_version")},
                      material={k: _text(v.item() if isinstance(v, np.generic) else v)
                                for k, v in h5["material"].attrs.items() if k != "description"},
                      scalars={key: float(h5[key][()]) for key in INCIDENCE_AXES
                               if key not in names and key in h5},
                      path=location)
    sweep.attrs["vcavity_version"] = attrs.get("vcavity_version")
    sweep.attrs["created_utc"] = attrs.get("created_utc")
    for name, (_, dtype, *_rest) in VARIABLES.items():
        if name in OPTIONAL and name not in h5:
            continue
        array = h5[name][()]
        sizes = {a.name: len(a.values) for a in axes}
        sizes.update(order=len(sweep.order), cell=len(sweep.cells["theta_o"]))
        expected = tuple(sizes[d] for d in sweep.dims(name))
        if array.shape != expected:
            raise SweepFormatError(f"sweep {str(location)!r}: dataset {name} has shape {array.shape}, "
                                   f"expected {expected}")
        if np.issubdtype(dtype, np.integer):  # a fractional count is refused, not truncated
            checks.check_integer(name, array, f"sweep {str(location)!r}")
        else:
            checks.check_numeric(name, array, f"sweep {str(location)!r}")
        sweep.data[name] = array.astype(dtype, copy=False)
    _verify(sweep)
    radians = {name: h5[name][()] for name in RADIANS.values() if name in h5}
    checks.check_sweep(sweep, radians, f"sweep {str(location)!r}")
    return sweep


def _verify(sweep: SweepData) -> None:
    """Read a point as done only where its checksum matches; give every point not done
    the values of a pending point (a write cut short may have left some of its bytes)."""
    done = sweep.data["done"]  # flags out of range stay as read: check_sweep refuses them
    if "checksum" not in sweep.data:  # written before checksums: done flags as stored; the
        # checksums are set when the sweep is next written (write_sweep seals every done point)
        sweep.data["checksum"] = np.zeros(done.shape, np.uint64)
        return
    dims = {name: sweep.dims(name) for name in sweep.data}
    good = sweep_checksum.verified(sweep.data, dims, sweep.point_axes, done, sweep.data["checksum"])
    sweep.rejected = tuple(tuple(int(i) for i in index) for index in np.ndindex(done.shape)
                           if done[index] == 1 and not good[index])
    for index in np.ndindex(done.shape):
        if done[index] == 1 and not good[index]:
            done[index] = 0
        if done[index] == 0:
            sweep.reset(index)


def spec_of(sweep: SweepData) -> dict:
    """The sweep specification stored in the file (the parsed ``spec`` attribute)."""
    return json.loads(sweep.attrs.get("spec", "{}"))


__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "OPTIONAL", "GridAxis", "SweepData", "SweepFormatError", "VARIABLES",
           "is_sweep_file", "open_sweep", "spec_of", "write_sweep"]
