"""Writing BRDF tables (format v3, :mod:`vcavity.io.schema`), atomically.

The writer stores a :class:`~vcavity.io.schema.TableValue`, which an estimator made
(:func:`vcavity.estimators.tabulate.tabulate`): every dataset under its schema name, the
``/material`` attributes and the run's root attributes. It computes nothing: it checks the
value as :func:`vcavity.io.table.open_table` checks a file (:func:`vcavity.io.checks.check_table`),
so vcavity never writes what it would refuse to read, then writes it with the axis scales,
units and descriptions of the schema, to a temporary file renamed into place.
"""

from __future__ import annotations

import datetime
import json
import os

import numpy as np

from vcavity._version import __version__ as _VCAVITY_VERSION
from vcavity.io import checks, schema
from vcavity.io.atomic import write_hdf5

#: Root attributes stored as integers (the others: strings and float64).
_INTEGER_ATTRS = ("sensor_resolution", "n_cells", "seed", "block_size", "max_bounces", "deterministic")


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


def _material_attr(key: str, value):
    """A material value as an attribute every netCDF reader keeps.

    HDF5 has no boolean type: h5py writes an enum, which netCDF-C silently drops, so
    booleans are stored as int8 0/1. Integers are int64 (uint64 from 2**63 on).
    """
    if isinstance(value, (bool, np.bool_)):
        return np.int8(bool(value))
    if isinstance(value, (int, np.integer)):
        if not -2**63 <= int(value) < 2**64:
            raise ValueError(f"material[{key!r}] = {value} does not fit in 64 bits")
        return np.int64(value) if int(value) < 2**63 else np.uint64(value)
    if isinstance(value, (float, np.floating)):
        return np.float64(value)
    if isinstance(value, str):
        return value
    raise TypeError(f"material[{key!r}] must be a str, bool, int or float, "
                    f"got {type(value).__name__}")


def check_table(value: schema.TableValue, location) -> None:
    """Refuse a table value that :func:`vcavity.io.table.open_table` would refuse as a file.

    Raises
    ------
    ValueError
        One line naming the dataset or attribute (a :class:`vcavity.io.checks.TableFormatError`).
    """
    missing = [name for name in schema.DATASETS if name not in value.datasets]
    if missing:
        raise ValueError(f"table value for {location} lacks the dataset(s) {', '.join(missing)}")
    data = {name: np.asarray(value.datasets[name]) for name in schema.DATASETS
            if name not in ("incidence", "cell", "xyz")}
    for name, array in data.items():
        wanted = np.dtype(schema.DTYPES.get(name, "float64"))
        if array.dtype != wanted:
            raise checks.TableFormatError(f"dataset '{name}' has dtype {array.dtype} in {location}: "
                                          f"must be {wanted}")
    for name in ("sensor_partition", "sensor_resolution", "n_cells", "seed", "block_size", "max_bounces",
                 "config", "deterministic"):
        if name not in value.attrs:
            raise ValueError(f"table value for {location} lacks the attribute {name!r}")
    checks.check_shapes(data, checks.int_attribute(value.attrs, "n_cells", location, 1), location)
    sensor = checks.sensor_of(value.attrs, data["cell_center"], location)
    checks.check_sensor_datasets(data, sensor, location)
    deterministic = bool(value.attrs["deterministic"])
    checks.check_values(data, location, deterministic)
    checks.check_estimator_name(value.attrs.get("estimator"), location)
    checks.check_order_source(data["order_source"], deterministic, location)
    if not isinstance(value.material, dict) or not {"distribution", "facet"} <= value.material.keys():
        raise ValueError("material must be a dict with at least 'distribution' and 'facet'")
    if "description" in value.material:
        raise ValueError("'description' is reserved in /material and cannot be a material key")


def _write_datasets(h5, values: dict) -> None:
    """Create every dataset of the schema with its attributes, and attach the axis scales.

    Each axis has exactly one scale (the dataset named like the axis); netCDF readers
    take an axis' name from the scale attached to it, so nothing else may be attached.
    """
    for name, (axes, units, long_name, description) in schema.DATASETS.items():
        data = values[name]
        options = {}
        if data.ndim == 3:  # one chunk = all orders and cells of one incidence
            options = dict(chunks=(1,) + data.shape[1:], compression="gzip",
                           compression_opts=schema.GZIP_LEVEL, shuffle=True)
        dataset = h5.create_dataset(name, data=data, track_order=True, **options)
        if units is not None:
            dataset.attrs["units"] = units
        dataset.attrs["long_name"] = long_name
        dataset.attrs["description"] = description
        if name in schema.FLAGS:  # CF flags: xarray and ncdump show the meanings
            flag_values, flag_meanings = schema.FLAGS[name]
            dataset.attrs["flag_values"] = np.array(flag_values, dtype=np.int8)
            dataset.attrs["flag_meanings"] = flag_meanings
        coordinates = schema.coordinates_attribute(name)
        if coordinates is not None:
            dataset.attrs["coordinates"] = coordinates  # CF: auxiliary coordinate variables
        if schema.is_scale(name):
            dataset.make_scale(name)
        else:
            for position, axis in enumerate(axes):
                dataset.dims[position].attach_scale(h5[axis])


def _write_material(h5, material: dict) -> None:
    group = h5.create_group("material", track_order=True)
    group.attrs["description"] = schema.MATERIAL_DESCRIPTION
    for key, value in material.items():
        if value is None:
            continue  # parameters that do not apply to this distribution are omitted
        group.attrs[key] = _material_attr(key, value)


def _root_attributes(attrs: dict) -> dict:
    """The format's own root attributes, then the run's (docs/hdf5-format.md), typed for HDF5."""
    root = {
        "format": schema.FORMAT_NAME, "format_version": np.int64(schema.FORMAT_VERSION),
        "description": schema.ROOT_DESCRIPTION, "conventions": schema.CONVENTIONS,
        "vcavity_version": _VCAVITY_VERSION,
        "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }
    for key, value in attrs.items():
        if key == "config":
            root[key] = json.dumps(value, sort_keys=True, default=_json_fallback)
        elif key in _INTEGER_ATTRS:
            root[key] = _int_attr(key, value)
        else:
            root[key] = value if isinstance(value, str) else float(value)
    return root


def write_table(path, value: schema.TableValue, cancelled=None) -> None:
    """Write a BRDF table (format v3) atomically.

    The file is written to a temporary file in the destination directory, fsynced and
    renamed onto ``path`` (:func:`vcavity.io.atomic.write_hdf5`); on any failure the
    temporary file is removed and an existing file at ``path`` is left untouched.

    Parameters
    ----------
    path : str or os.PathLike
    value : vcavity.io.schema.TableValue
        Every dataset, the material and the run's root attributes
        (:func:`vcavity.estimators.tabulate.tabulate` makes it); checked by :func:`check_table`.
    cancelled : callable, optional
        ``cancelled() -> bool``, asked once the temporary file is complete and synced,
        just before the rename: True (Ctrl-C was pressed meanwhile) removes the
        temporary file, leaves ``path`` untouched and raises ``KeyboardInterrupt``.

    Raises
    ------
    KeyboardInterrupt
        ``cancelled()`` returned True; nothing was written.
    OSError
        The file could not be written (disk full, ...); ``path`` is untouched and no
        temporary file is left.
    ValueError
        A value no reader would accept (:func:`check_table`); nothing was written.
    """
    check_table(value, path)
    values = {name: np.asarray(value.datasets[name]) for name in schema.DATASETS}
    root_attrs = _root_attributes(dict(value.attrs))
    material = dict(value.material)

    def build(h5) -> None:
        h5.attrs.update(root_attrs)
        _write_datasets(h5, values)
        _write_material(h5, material)

    # Creation order tracked everywhere: readers list datasets and attributes in the
    # order written, and older netCDF-C versions require it.
    write_hdf5(path, build, cancelled=cancelled, track_order=True)


__all__ = ["check_table", "write_table"]
