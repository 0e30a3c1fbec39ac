"""Writing BRDF tables (format v2, :mod:`vcavity.io.schema`), atomically.

Everything stored that is derived (``brdf``, ``brdf_stderr``, ``albedo`` and the path
fractions) is computed here from the integer counts, so a file is always consistent
with its own ``counts`` and ``paths`` (physics.md section 6)::

    brdf[c] = (1/Ω⊥_c) ∫_c f_k(i, o) cos θ_o dω_o  ≈  counts[c] / (paths Ω⊥_c)
"""

from __future__ import annotations

import datetime
import json
import os

import numpy as np

from vcavity._version import __version__ as _VCAVITY_VERSION
from vcavity.io import schema
from vcavity.io.atomic import write_hdf5


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


def _degrees(name: str, given, radians: np.ndarray) -> np.ndarray:
    """``given`` (the user's degrees) checked against ``radians``, or degrees(radians)."""
    if given is None:
        return np.degrees(radians)
    degrees = np.asarray(given, dtype=np.float64)
    if degrees.shape != radians.shape:
        raise ValueError(f"{name} must have shape {radians.shape}, got {degrees.shape}")
    if not np.allclose(np.radians(degrees), radians, rtol=1e-12, atol=1e-12):
        raise ValueError(f"{name} = {degrees.tolist()} does not match the angles in radians "
                         f"{radians.tolist()}")
    return degrees


def _validated(theta_i, phi_i, order, counts, paths, lost_paths, max_bounces_seen, sensor,
               material, unbinned, deterministic=False):
    """Check shapes and bookkeeping of write_table's inputs; returns per-order exits."""
    n_i = theta_i.shape[0] if theta_i.ndim == 1 else 0
    if n_i < 1:
        raise ValueError(f"theta_i must be a non-empty 1-D array, got shape {theta_i.shape}")
    named = {"phi_i": phi_i, "paths": paths, "max_bounces_seen": max_bounces_seen,
             "unbinned_paths": unbinned, **lost_paths}
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
    if deterministic:  # a model's table: no path was traced, nothing counted
        if np.any(paths != 0) or np.any(counts != 0):
            raise ValueError("a deterministic table has no paths and no counts (all 0)")
        return counts.sum(axis=2)
    if np.any(paths <= 0):
        raise ValueError("paths must be positive for every incident direction")
    # Bookkeeping (physics.md sec. 6): exits + absorbed + truncated + degenerate = paths
    # (exact-f1: the first-order exits are counted in unbinned_paths, not in cells).
    exits = counts.sum(axis=2)
    lost = sum(lost_paths.values()) + unbinned
    if np.any(exits + lost[:, None] > paths[:, None]):
        raise ValueError("exits + absorbed + truncated + degenerate paths exceed paths")
    if start == 0 and np.any(exits[:, 0] + lost != paths):
        raise ValueError("order-0 exits + unbinned + absorbed + truncated + degenerate paths != paths")
    if start == 0 and np.any(counts[:, 1:, :].sum(axis=1) > counts[:, 0, :]):
        raise ValueError("order-k counts exceed the all-orders (order 0) counts of a cell")
    if not isinstance(material, dict) or not {"distribution", "facet"} <= material.keys():
        raise ValueError("material must be a dict with at least 'distribution' and 'facet'")
    if "description" in material:
        raise ValueError("'description' is reserved in /material and cannot be a material key")
    return exits


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


def _root_attributes(sensor, config: dict, seed, block_size, max_bounces, compute_time_s, compile_time_s,
                     run_attrs, deterministic=False) -> dict:
    """The root attributes of a table: format, conventions, sensor, run metadata (docs/hdf5-format.md)."""
    config_json = json.dumps(config, sort_keys=True, default=_json_fallback)
    root_attrs = {
        "format": schema.FORMAT_NAME, "format_version": np.int64(schema.FORMAT_VERSION),
        "description": schema.ROOT_DESCRIPTION, "conventions": schema.CONVENTIONS,
        "vcavity_version": _VCAVITY_VERSION,
        "created_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "sensor_partition": str(sensor.partition),
        "sensor_resolution": np.int64(sensor.resolution), "n_cells": np.int64(sensor.n_cells),
        "seed": _int_attr("seed", seed), "block_size": _int_attr("block_size", block_size),
        "max_bounces": _int_attr("max_bounces", max_bounces), "config": config_json,
        "compute_time_s": float(compute_time_s), "compile_time_s": float(compile_time_s),
        "estimator": "analog", "target_error": float("nan"),
        "deterministic": np.int64(1 if deterministic else 0),
    }
    for key, value in (run_attrs or {}).items():
        root_attrs[key] = value if isinstance(value, str) else float(value)
    return root_attrs


def _analog_values(theta_i, phi_i, theta_i_deg, phi_i_deg, order, counts, paths, exits, lost_paths,
                   max_bounces_seen, unbinned, sensor) -> dict:
    """Every dataset of a table, as the analog estimator of the integer counts gives it
    (physics.md sec. 6); another estimator's values replace some of them (:func:`_tabulated`)."""
    proj_solid_angle = np.asarray(sensor.cell_projected_solid_angle, dtype=np.float64)
    paths_f = paths.astype(np.float64)
    counts_f = counts.astype(np.float64)
    denominator = paths_f[:, None, None] * proj_solid_angle  # N_paths Ω⊥_c (physics.md sec. 6)
    values = {
        "incidence": np.arange(theta_i.size, dtype=np.int64), "order": order,
        "cell": np.arange(sensor.n_cells, dtype=np.int64),
        "xyz": np.array([b"x", b"y", b"z"], dtype="S1"),
        "theta_i": theta_i, "phi_i": phi_i, "theta_i_deg": theta_i_deg, "phi_i_deg": phi_i_deg,
        "theta_o": np.asarray(sensor.cell_theta, dtype=np.float64),
        "phi_o": np.asarray(sensor.cell_phi, dtype=np.float64),
        "brdf": counts_f / denominator,
        # Multinomial standard error of a cell count: sqrt(n p (1 - p)), p = counts / paths.
        "brdf_stderr": np.sqrt(counts_f * (1.0 - counts_f / paths_f[:, None, None])) / denominator,
        "counts": counts,
        "albedo": exits / paths_f[:, None],  # = Σ_c brdf Ω⊥_c, from integers (exact rounding)
        "absorbed": lost_paths["absorbed_paths"] / paths_f,
        "truncated": lost_paths["truncated_paths"] / paths_f,
        "degenerate": lost_paths["degenerate_paths"] / paths_f,
        "paths": paths, "max_bounces_seen": max_bounces_seen,
        "order_source": np.zeros(order.size, np.int8), "unbinned_paths": unbinned,
        "folded": np.zeros(theta_i.size, np.int8),
        "relative_error": _analog_relative_error(counts, paths, order),
        "target_reached": np.full(theta_i.size, -1, np.int8),
        "cell_center": np.asarray(sensor.cell_center, dtype=np.float64),
        "cell_solid_angle": np.asarray(sensor.cell_solid_angle, dtype=np.float64),
        "cell_projected_solid_angle": proj_solid_angle,
    }
    return values


def write_table(path, *, theta_i, phi_i, order, counts, paths, absorbed_paths,
                truncated_paths, degenerate_paths, max_bounces_seen, sensor,
                material: dict, config: dict, seed: int, block_size: int,
                max_bounces: int, compute_time_s: float = 0.0,
                compile_time_s: float = 0.0, theta_i_deg=None, phi_i_deg=None,
                unbinned_paths=None, tabulated=None, run_attrs=None, cancelled=None,
                deterministic=False) -> None:
    """Write a BRDF table (format v3) atomically.

    Derived datasets come from the integer counts (physics.md sec. 6):
    ``brdf = counts / (paths Ω⊥_c)``, ``brdf_stderr = sqrt(counts (1 - counts/paths)) /
    (paths Ω⊥_c)``, ``albedo = Σ_c counts / paths`` (= Σ_c brdf Ω⊥_c) and each fraction =
    its path count / paths. The file is written to a temporary file in the destination
    directory, fsynced and renamed onto ``path`` (:func:`vcavity.io.atomic.write_hdf5`);
    on any failure the temporary file is removed and an existing file at ``path`` is left
    untouched.

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
        ``/material`` (booleans as int8 0/1), ``None`` values are omitted.
    config : dict
        Fully resolved run configuration (stored as JSON).
    seed, block_size, max_bounces : int
        RNG seed, paths per RNG block, bounce cap (each in ``[0, 2**64)``).
    compute_time_s, compile_time_s : float, optional
    theta_i_deg, phi_i_deg : array_like (n_i,), optional
        The incident angles in degrees exactly as the user wrote them (stored as
        ``theta_i_deg``, ``phi_i_deg``); they must equal ``theta_i``, ``phi_i`` up to
        rounding. Default ``np.degrees`` of the radians.
    unbinned_paths : array_like of int (n_i,), optional
        Exact-f1: first-order exits counted but not binned (default 0).
    tabulated : dict, optional
        What an estimator other than plain analog tabulates (:mod:`vcavity.estimators`):
        ``brdf``, ``brdf_stderr`` (n_i, n_k, n_c), ``albedo`` (n_i, n_k), and optionally
        ``order_source`` (n_k,), ``folded``, ``relative_error``, ``target_reached``
        (n_i,). Default: the analog estimator of the counts, unfolded.
    run_attrs : dict, optional
        Further root attributes (``estimator``, ``target_error``, ...; str or float).
    deterministic : bool, optional
        A model's table (the ``exact`` estimator): ``paths`` and ``counts`` are all 0 and
        ``tabulated`` holds every value (including the lost fractions); the root attribute
        ``deterministic`` is 1.
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
    ValueError, TypeError
        Inconsistent inputs (shapes, negative counts, more paths counted than simulated,
        with order 0: exits + absorbed + truncated + degenerate != paths, or degrees that
        do not match the radians).
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
    unbinned = _as_int64("unbinned_paths", np.zeros_like(paths) if unbinned_paths is None
                         else unbinned_paths, 1)
    exits = _validated(theta_i, phi_i, order, counts, paths, lost_paths, max_bounces_seen,
                       sensor, material, unbinned, deterministic)
    if deterministic and (tabulated is None or not {"brdf", "brdf_stderr", "albedo", "absorbed", "truncated",
                                                    "degenerate", "relative_error"} <= tabulated.keys()):
        raise ValueError("a deterministic table needs every tabulated value (brdf, brdf_stderr, albedo, "
                         "the lost fractions and relative_error)")
    theta_i_deg = _degrees("theta_i_deg", theta_i_deg, theta_i)
    phi_i_deg = _degrees("phi_i_deg", phi_i_deg, phi_i)
    root_attrs = _root_attributes(sensor, config, seed, block_size, max_bounces, compute_time_s,
                                  compile_time_s, run_attrs, deterministic)
    with np.errstate(divide="ignore", invalid="ignore"):  # deterministic: NaN, replaced below
        values = _analog_values(theta_i, phi_i, theta_i_deg, phi_i_deg, order, counts, paths, exits, lost_paths,
                                max_bounces_seen, unbinned, sensor)

    if tabulated is not None:
        values.update(_tabulated(tabulated, values))

    def build(h5) -> None:
        h5.attrs.update(root_attrs)
        _write_datasets(h5, values)
        _write_material(h5, material)

    # Creation order tracked everywhere: readers list datasets and attributes in the
    # order written, and older netCDF-C versions require it.
    write_hdf5(path, build, cancelled=cancelled, track_order=True)


def write_result(path, result, config, cancelled=None) -> None:
    """Write the table of a finished run (``vcavity.simulate.pipeline.RunResult``) atomically.

    Parameters
    ----------
    path : str or os.PathLike
    result : vcavity.simulate.pipeline.RunResult
        Counts, bookkeeping and the estimator's tabulated values.
    config : vcavity.config.RunConfig
        The run's validated configuration (stored in full, with the seed).
    cancelled : callable, optional
        As in :func:`write_table`: asked just before the rename.
    """
    incidence = config.incidence
    tabulated = {"brdf": result.brdf, "brdf_stderr": result.brdf_stderr, "albedo": result.albedo,
                 "order_source": result.order_source, "folded": result.folded,
                 "relative_error": result.relative_error}
    if result.target_reached is not None:
        tabulated["target_reached"] = result.target_reached
    if result.lost_fractions is not None:  # weighted estimator: energy, not path, fractions
        for position, name in enumerate(("absorbed", "truncated", "degenerate")):
            tabulated[name] = result.lost_fractions[:, position]
    run_attrs = {"estimator": result.estimator, "model_time_s": result.model_time_s,
                 "model_error_ratio": result.model_error_ratio}
    if config.target_error is not None:
        run_attrs["target_error"] = config.target_error
    write_table(
        path, theta_i=result.theta_i, phi_i=result.phi_i, order=result.order, counts=result.counts,
        theta_i_deg=[d.theta_i_deg for d in incidence], phi_i_deg=[d.phi_i_deg for d in incidence],
        paths=result.paths, absorbed_paths=result.absorbed_paths,
        truncated_paths=result.truncated_paths, degenerate_paths=result.degenerate_paths,
        max_bounces_seen=result.max_bounces_seen, unbinned_paths=result.unbinned_paths,
        sensor=result.sensor, material=config.material.to_dict(), config=config.to_dict(),
        seed=config.seed, block_size=result.block_size, max_bounces=config.effective_max_bounces,
        compute_time_s=result.compute_time_s, compile_time_s=result.compile_time_s,
        tabulated=tabulated, run_attrs=run_attrs, cancelled=cancelled, deterministic=result.estimator == "exact")


def _analog_relative_error(counts, paths, order) -> np.ndarray:
    """Energy-weighted relative standard error of f_inf from counts (NaN without order 0)."""
    if order[0] != 0:
        return np.full(paths.size, np.nan)
    n = counts[:, 0, :].astype(np.float64)
    total = n.sum(axis=1)
    spread = np.sqrt(n * (1.0 - n / paths[:, None])).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total > 0, spread / np.maximum(total, 1.0), np.inf)


def _tabulated(tabulated: dict, values: dict) -> dict:
    """Check an estimator's arrays against the analog defaults' shapes and dtypes."""
    out = {}
    for name, array in tabulated.items():
        if name not in values or name in ("counts", "paths"):
            raise ValueError(f"tabulated[{name!r}] is not an estimator output")
        reference = values[name]
        array = np.asarray(array, dtype=reference.dtype)
        if array.shape != reference.shape:
            raise ValueError(f"tabulated[{name!r}] must have shape {reference.shape}, got {array.shape}")
        if name in ("brdf", "brdf_stderr", "albedo") and not np.all(np.isfinite(array) & (array >= 0)):
            raise ValueError(f"tabulated[{name!r}] must be finite and non-negative")
        out[name] = array
    return out


__all__ = ["write_result", "write_table"]
