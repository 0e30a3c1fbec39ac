"""HDF5 BRDF tables, format v1: write, validate and read back.

This is the only module of vcavity that imports h5py. The layout is documented in
``docs/hdf5-format.md``; the tabulated quantity is the cell-averaged, cosine-weighted
BRDF of physics.md section 6::

    brdf[c] = (1/Ω⊥_c) ∫_c f_k(i, o) cos θ_o dω_o  ≈  counts[c] / (paths Ω⊥_c)

Everything stored that is derived (``brdf``, ``brdf_stderr``, ``albedo`` and the path
fractions) is computed here from the integer counts, so a file is always consistent
with its own ``counts`` and ``paths``.
"""

from __future__ import annotations

import datetime
import errno
import json
import os
import secrets
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from vcavity import __version__ as _VCAVITY_VERSION
from vcavity.sensor import EqualAreaSensor

FORMAT_NAME = "vcavity-brdf-table"
FORMAT_VERSION = 1

# The v1 layout: dataset -> (axes, units, description). Axis names are the HDF5 dimension
# labels; _SCALES names the dimension-scale datasets of each axis. units None = not physical.
_SCHEMA = {
    "theta_i": (("incidence",), "rad", "Polar angle of the incident direction i, from +z"),
    "phi_i": (("incidence",), "rad", "Azimuth of the incident direction i, from +x toward +y"),
    "order": (("order",), "1", "Bounce order: 0 = all orders together (f_inf), "
              "k >= 1 = paths that left after exactly k bounces"),
    "cell": (("cell",), "1", "Sensor cell index, as returned by the sensor's cell_index"),
    "xyz": (("xyz",), None, "Cartesian component of a direction (macro normal = z)"),
    "brdf": (("incidence", "order", "cell"), "1/sr",
             "Cell-averaged cosine-weighted BRDF (1/Ω⊥_c) ∫_c f_k(i,o) cos(theta_o) dω_o, "
             "estimated as counts / (paths * cell_projected_solid_angle)"),
    "brdf_stderr": (("incidence", "order", "cell"), "1/sr",
                    "Standard error of brdf (multinomial): sqrt(counts (1 - counts/paths)) "
                    "/ (paths * cell_projected_solid_angle)"),
    "counts": (("incidence", "order", "cell"), "1",
               "Number of paths of this order that exited through this cell"),
    "albedo": (("incidence", "order"), "1", "Fraction of paths leaving with this order: "
               "sum over cells of brdf * cell_projected_solid_angle"),
    "absorbed": (("incidence",), "1", "Fraction of paths absorbed inside a facet body"),
    "truncated": (("incidence",), "1", "Fraction of paths stopped at the bounce cap "
                  "max_bounces (their energy is in no cell)"),
    "degenerate": (("incidence",), "1", "Fraction of paths the walk could not trace "
                   "(numerically degenerate geometry)"),
    "paths": (("incidence",), "1", "Number of paths simulated for this incident direction"),
    "max_bounces_seen": (("incidence",), "1",
                         "Largest number of bounces made by any path of this incident direction"),
    "cell_center": (("cell", "xyz"), "1", "Unit direction at the centre of each sensor cell"),
    "cell_solid_angle": (("cell",), "sr", "Solid angle of each sensor cell"),
    "cell_projected_solid_angle": (("cell",), "sr", "Projected solid angle of each sensor "
                                   "cell: integral of cos(theta_o) over the cell"),
}
_SCALES = {"incidence": ("theta_i", "phi_i"), "order": ("order",), "cell": ("cell",),
           "xyz": ("xyz",)}
_REQUIRED_ROOT_ATTRS = ("vcavity_version", "sensor_partition", "sensor_resolution", "n_cells",
                        "seed", "block_size", "max_bounces", "config")
# Root attributes that become their own Table fields (everything else goes to Table.attrs).
_ROOT_ATTRS_AS_FIELDS = ("format_version", "vcavity_version", "seed", "config")

_CONVENTIONS = (
    "Macrosurface normal +z; all directions point away from the surface (incident "
    "direction i toward the light, outgoing o toward the viewer); theta measured from +z, "
    "phi measured from +x toward +y; angles in radians, solid angles in sr, BRDF in 1/sr."
)
_ROOT_DESCRIPTION = (
    "Monte-Carlo BRDF of a microfacet V-cavity surface, per incident direction and "
    "bounce order, averaged over the cells of an equal-solid-angle hemispherical sensor: "
    "brdf[i, k, c] = counts[i, k, c] / (paths[i] * cell_projected_solid_angle[c]). "
    "Layout: docs/hdf5-format.md of vcavity."
)
_GZIP_LEVEL = 4


class TableFormatError(ValueError):
    """A file is not a readable vcavity table (wrong kind, version or content)."""


@dataclass(frozen=True, eq=False)
class Table:
    """Everything a vcavity table holds, read into memory (arrays are read-only).

    Axes: incidence ``n_i``, order ``n_k``, cell ``n_c``; see docs/hdf5-format.md.

    Attributes
    ----------
    path : pathlib.Path
    theta_i, phi_i : ndarray (n_i,)
        Incident direction in rad (theta from +z, phi from +x toward +y).
    order : ndarray of int64 (n_k,)
        Bounce orders: 0 = all orders together (``f_inf``), then 1..K.
    brdf, brdf_stderr : ndarray (n_i, n_k, n_c)
        Cell-averaged cosine-weighted BRDF and its standard error, 1/sr.
    counts : ndarray of int64 (n_i, n_k, n_c)
    albedo : ndarray (n_i, n_k)
    absorbed, truncated, degenerate : ndarray (n_i,)
        Fractions of paths.
    paths, max_bounces_seen : ndarray of int64 (n_i,)
    cell_center, cell_solid_angle, cell_projected_solid_angle : ndarray (n_c, 3), (n_c,)
    sensor : EqualAreaSensor
        Rebuilt from the stored resolution; bins exactly as the run did.
    material, config : dict
        The ``/material`` attributes and the parsed resolved run configuration.
    seed, format_version : int
    vcavity_version : str
    attrs : dict
        The remaining root attributes (``block_size``, ``max_bounces``, ...).
    """

    path: Path
    theta_i: np.ndarray
    phi_i: np.ndarray
    order: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray
    counts: np.ndarray
    albedo: np.ndarray
    absorbed: np.ndarray
    truncated: np.ndarray
    degenerate: np.ndarray
    paths: np.ndarray
    max_bounces_seen: np.ndarray
    cell_center: np.ndarray
    cell_solid_angle: np.ndarray
    cell_projected_solid_angle: np.ndarray
    sensor: EqualAreaSensor
    material: dict
    config: dict
    seed: int
    format_version: int
    vcavity_version: str
    attrs: dict = field(default_factory=dict)

    def order_index(self, k: int) -> int:
        """Position of bounce order ``k`` on the order axis (``self.order[j] == k``).

        Raises
        ------
        ValueError
            If order ``k`` is not in the table.
        """
        hits = np.flatnonzero(self.order == k)
        if hits.size == 0:
            present = ", ".join(str(int(o)) for o in self.order)
            raise ValueError(f"order {k} is not in table {self.path} (orders present: {present})")
        return int(hits[0])


# ----------------------------------------------------------------------------- writing


def _as_int64(name: str, value, shape_ndim: int) -> np.ndarray:
    array = np.asarray(value)
    if array.ndim != shape_ndim:
        raise ValueError(f"{name} must have {shape_ndim} dimension(s), got shape {array.shape}")
    if array.size and not np.issubdtype(array.dtype, np.integer):
        raise TypeError(f"{name} must hold integers, got dtype {array.dtype}")
    if array.size and array.min() < 0:
        raise ValueError(f"{name} must be non-negative")
    return array.astype(np.int64)


def _json_fallback(value):
    """Make NumPy scalars/arrays and paths inside a config JSON-serialisable."""
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"config value of type {type(value).__name__} is not JSON serialisable")


def _int_attr(name: str, value) -> np.integer:
    value = int(value)
    if not 0 <= value < 2**64:
        raise ValueError(f"{name} must be an integer in [0, 2**64), got {value}")
    return np.int64(value) if value < 2**63 else np.uint64(value)


def _validated(theta_i, phi_i, order, counts, paths, lost_paths, max_bounces_seen, sensor,
               material):
    """Check shapes and bookkeeping of write_table's inputs; returns per-order exits."""
    n_i = theta_i.shape[0] if theta_i.ndim == 1 else 0
    if n_i < 1:
        raise ValueError(f"theta_i must be a non-empty 1-D array, got shape {theta_i.shape}")
    named = {"phi_i": phi_i, "paths": paths, "max_bounces_seen": max_bounces_seen, **lost_paths}
    for name, array in named.items():
        if array.shape != (n_i,):
            raise ValueError(f"{name} must have shape ({n_i},), got {array.shape}")
    if not (np.all((theta_i >= 0.0) & (theta_i <= 0.5 * np.pi)) and np.all(np.isfinite(phi_i))):
        raise ValueError("theta_i must lie in [0, pi/2] and phi_i must be finite (radians)")
    start = 0 if order.size and order[0] == 0 else 1
    if order.size == 0 or not np.array_equal(order, np.arange(start, start + order.size)):
        raise ValueError(f"order must be 1..K or 0, 1..K; got {order.tolist()}")
    expected_shape = (n_i, order.size, int(sensor.n_cells))
    if counts.shape != expected_shape:
        raise ValueError(f"counts must have shape (incidence, order, cell) = {expected_shape}, "
                         f"got {counts.shape}")
    if np.any(paths <= 0):
        raise ValueError("paths must be positive for every incident direction")
    # Bookkeeping (physics.md sec. 6): exits + absorbed + truncated + degenerate = paths.
    exits = counts.sum(axis=2)
    lost = sum(lost_paths.values())
    if np.any(exits + lost[:, None] > paths[:, None]):
        raise ValueError("exits + absorbed + truncated + degenerate paths exceed paths")
    if start == 0 and np.any(exits[:, 0] + lost != paths):
        raise ValueError("order-0 exits + absorbed + truncated + degenerate paths != paths")
    if start == 0 and np.any(counts[:, 1:, :].sum(axis=1) > counts[:, 0, :]):
        raise ValueError("order-k counts exceed the all-orders (order 0) counts of a cell")
    if not isinstance(material, dict) or not {"distribution", "facet"} <= material.keys():
        raise ValueError("material must be a dict with at least 'distribution' and 'facet'")
    if "description" in material:
        raise ValueError("'description' is reserved in /material and cannot be a material key")
    return exits


def _write_datasets(h5, values: dict) -> None:
    """Create every dataset of _SCHEMA with its units/description, scales and labels."""
    for name, (_, units, description) in _SCHEMA.items():
        data = values[name]
        options = {}
        if data.ndim == 3:  # one chunk = all orders and cells of one incidence
            options = dict(chunks=(1,) + data.shape[1:], compression="gzip",
                           compression_opts=_GZIP_LEVEL, shuffle=True)
        dataset = h5.create_dataset(name, data=data, **options)
        if units is not None:
            dataset.attrs["units"] = units
        dataset.attrs["description"] = description
    for scales in _SCALES.values():
        for name in scales:
            h5[name].make_scale(name)
    for name, (axes, _, _) in _SCHEMA.items():
        for axis, label in enumerate(axes):
            h5[name].dims[axis].label = label
            if not h5[name].is_scale:  # a scale cannot carry scales itself
                for scale in _SCALES[label]:
                    h5[name].dims[axis].attach_scale(h5[scale])


def _write_material(h5, material: dict) -> None:
    group = h5.create_group("material")
    group.attrs["description"] = (
        "Material of the microsurface: microfacet distribution and its parameters, facet "
        "model, diffuse albedo kd and relative index of refraction eta (docs/hdf5-format.md)")
    for key, value in material.items():
        if value is None:
            continue  # parameters that do not apply to this distribution are omitted
        if not isinstance(value, (str, bool, int, float, np.generic)):
            raise TypeError(f"material[{key!r}] must be a str, bool, int or float, "
                            f"got {type(value).__name__}")
        group.attrs[key] = value


def write_table(path, *, theta_i, phi_i, order, counts, paths, absorbed_paths,
                truncated_paths, degenerate_paths, max_bounces_seen, sensor,
                material: dict, config: dict, seed: int, block_size: int,
                max_bounces: int, compute_time_s: float = 0.0,
                compile_time_s: float = 0.0) -> None:
    """Write a BRDF table (format v1) atomically.

    Derived datasets come from the integer counts (physics.md sec. 6):
    ``brdf = counts / (paths Ω⊥_c)``, ``brdf_stderr = sqrt(counts (1 - counts/paths)) /
    (paths Ω⊥_c)``, ``albedo = Σ_c counts / paths`` (= Σ_c brdf Ω⊥_c) and each fraction =
    its path count / paths. The file is written to a temporary file in the destination
    directory, fsynced and renamed onto ``path``; on any failure the temporary file is
    removed and an existing file at ``path`` is left untouched.

    Parameters
    ----------
    path : str or os.PathLike
    theta_i, phi_i : array_like (n_i,)
        Incident directions in radians, ``0 <= theta_i <= pi/2``.
    order : array_like of int (n_k,)
        ``1..K`` or ``0, 1..K``; 0 means all orders together.
    counts : array_like of int (n_i, n_k, n_c)
        Paths of each order exiting through each cell of ``sensor``.
    paths, absorbed_paths, truncated_paths, degenerate_paths : array_like of int (n_i,)
        Paths simulated (> 0), absorbed, stopped at the bounce cap, not traceable.
    max_bounces_seen : array_like of int (n_i,)
    sensor : EqualAreaSensor
    material : dict
        Must hold ``distribution`` and ``facet``; scalar values become attributes of
        ``/material``, ``None`` values are omitted.
    config : dict
        Fully resolved run configuration (stored as JSON).
    seed, block_size, max_bounces : int
        RNG seed, paths per RNG block, bounce cap.
    compute_time_s, compile_time_s : float, optional

    Raises
    ------
    ValueError, TypeError
        Inconsistent inputs (shapes, negative counts, more paths counted than simulated,
        or with order 0: exits + absorbed + truncated + degenerate != paths).
    """
    theta_i = np.asarray(theta_i, dtype=np.float64)
    phi_i = np.asarray(phi_i, dtype=np.float64)
    order = _as_int64("order", order, 1)
    counts = _as_int64("counts", counts, 3)
    paths = _as_int64("paths", paths, 1)
    max_bounces_seen = _as_int64("max_bounces_seen", max_bounces_seen, 1)
    lost_paths = {"absorbed_paths": _as_int64("absorbed_paths", absorbed_paths, 1),
                  "truncated_paths": _as_int64("truncated_paths", truncated_paths, 1),
                  "degenerate_paths": _as_int64("degenerate_paths", degenerate_paths, 1)}
    exits = _validated(theta_i, phi_i, order, counts, paths, lost_paths, max_bounces_seen,
                       sensor, material)
    config_json = json.dumps(config, sort_keys=True, default=_json_fallback)
    root_attrs = {
        "format": FORMAT_NAME, "format_version": np.int64(FORMAT_VERSION),
        "description": _ROOT_DESCRIPTION, "conventions": _CONVENTIONS,
        "vcavity_version": _VCAVITY_VERSION,
        "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "sensor_partition": str(sensor.partition),
        "sensor_resolution": np.int64(sensor.resolution), "n_cells": np.int64(sensor.n_cells),
        "seed": _int_attr("seed", seed), "block_size": _int_attr("block_size", block_size),
        "max_bounces": _int_attr("max_bounces", max_bounces), "config": config_json,
        "compute_time_s": float(compute_time_s), "compile_time_s": float(compile_time_s),
    }

    proj_solid_angle = np.asarray(sensor.cell_projected_solid_angle, dtype=np.float64)
    paths_f = paths.astype(np.float64)
    counts_f = counts.astype(np.float64)
    denominator = paths_f[:, None, None] * proj_solid_angle  # N_paths Ω⊥_c (physics.md sec. 6)
    values = {
        "theta_i": theta_i, "phi_i": phi_i, "order": order,
        "cell": np.arange(sensor.n_cells, dtype=np.int64),
        "xyz": np.array([b"x", b"y", b"z"], dtype="S1"),
        "brdf": counts_f / denominator,
        # Multinomial standard error of a cell count: sqrt(n p (1 - p)), p = counts / paths.
        "brdf_stderr": np.sqrt(counts_f * (1.0 - counts_f / paths_f[:, None, None])) / denominator,
        "counts": counts,
        "albedo": exits / paths_f[:, None],  # = Σ_c brdf Ω⊥_c, from integers (exact rounding)
        "absorbed": lost_paths["absorbed_paths"] / paths_f,
        "truncated": lost_paths["truncated_paths"] / paths_f,
        "degenerate": lost_paths["degenerate_paths"] / paths_f,
        "paths": paths, "max_bounces_seen": max_bounces_seen,
        "cell_center": np.asarray(sensor.cell_center, dtype=np.float64),
        "cell_solid_angle": np.asarray(sensor.cell_solid_angle, dtype=np.float64),
        "cell_projected_solid_angle": proj_solid_angle,
    }

    destination = Path(os.fspath(path))
    temporary = _create_temporary(destination)
    try:
        with h5py.File(temporary, "w") as h5:
            h5.attrs.update(root_attrs)
            _write_datasets(h5, values)
            _write_material(h5, material)
        _fsync(temporary)
        os.replace(temporary, destination)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    try:
        _fsync(destination.parent)  # make the rename durable; not possible everywhere
    except OSError:
        pass


def _create_temporary(destination: Path) -> Path:
    """Create an empty hidden file beside ``destination`` (mode 0666 minus the umask)."""
    while True:
        candidate = destination.with_name(f".{destination.name}.{secrets.token_hex(6)}.tmp")
        try:
            os.close(os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return candidate


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


# ----------------------------------------------------------------------------- reading


def _python_value(value) -> Any:
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    return value


def open_table(path) -> Table:
    """Read a vcavity BRDF table (format v1) into memory.

    Parameters
    ----------
    path : str or os.PathLike
        An HDF5 file written by :func:`write_table` (``vcavity run``).

    Returns
    -------
    Table

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    TableFormatError
        One-line message if the file is not HDF5, not a vcavity table, of another format
        version, lacks a dataset or attribute, or has inconsistent shapes.
    """
    location = Path(os.fspath(path))
    if not location.exists():
        raise FileNotFoundError(errno.ENOENT, "no such vcavity table", str(location))
    if location.is_dir() or not h5py.is_hdf5(location):
        raise TableFormatError(f"not a vcavity table: {location} (not an HDF5 file)")
    try:
        with h5py.File(location, "r") as h5:
            return _read(h5, location)
    except (OSError, KeyError) as exc:
        first_line = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise TableFormatError(f"cannot read vcavity table {location}: {first_line}") from exc


def _read(h5: h5py.File, location: Path) -> Table:
    root = h5.attrs
    if _python_value(root.get("format")) != FORMAT_NAME:
        raise TableFormatError(f"not a vcavity table: {location}")
    for name in ("format_version",) + _REQUIRED_ROOT_ATTRS:
        if name not in root:
            raise TableFormatError(f"missing attribute '{name}' in {location}")
    version = _python_value(root["format_version"])
    if version != FORMAT_VERSION:
        raise TableFormatError(f"unsupported format_version {version} in {location} "
                               f"(this vcavity reads {FORMAT_VERSION})")
    for name in _SCHEMA:
        if not isinstance(h5.get(name), h5py.Dataset):
            raise TableFormatError(f"missing dataset '{name}' in {location}")
    if not isinstance(h5.get("material"), h5py.Group):
        raise TableFormatError(f"missing group 'material' in {location}")

    data = {name: h5[name][()] for name in _SCHEMA if name not in ("cell", "xyz")}
    sizes = {"incidence": data["theta_i"].size, "order": data["order"].size,
             "cell": int(root["n_cells"]), "xyz": 3}
    for name, array in data.items():
        expected = tuple(sizes[axis] for axis in _SCHEMA[name][0])
        if array.shape != expected:
            raise TableFormatError(f"dataset '{name}' has shape {array.shape}, expected "
                                   f"{expected} in {location}")
        array.setflags(write=False)
    try:
        config = json.loads(_python_value(root["config"]))
    except (TypeError, ValueError) as exc:
        raise TableFormatError(f"attribute 'config' is not valid JSON in {location}") from exc
    return Table(
        path=location, sensor=_rebuild_sensor(root, data["cell_center"], location),
        material={key: _python_value(value) for key, value in h5["material"].attrs.items()
                  if key != "description"},
        config=config, seed=int(_python_value(root["seed"])), format_version=int(version),
        vcavity_version=str(_python_value(root["vcavity_version"])),
        attrs={key: _python_value(value) for key, value in root.items()
               if key not in _ROOT_ATTRS_AS_FIELDS},
        **data,
    )


def _rebuild_sensor(root, cell_center: np.ndarray, location: Path) -> EqualAreaSensor:
    """Rebuild the run's sensor and check that it reproduces the stored cell centres."""
    resolution = int(_python_value(root["sensor_resolution"]))
    sensor = EqualAreaSensor(resolution)
    partition = _python_value(root["sensor_partition"])
    if partition != sensor.partition:
        raise TableFormatError(f"table uses sensor partition '{partition}', this vcavity "
                               f"provides '{sensor.partition}' in {location}")
    if sensor.n_cells != cell_center.shape[0] or not np.allclose(
            sensor.cell_center, cell_center, rtol=0.0, atol=1e-12):
        raise TableFormatError(f"sensor of resolution {resolution} does not reproduce the "
                               f"stored cell centres in {location}")
    return sensor
