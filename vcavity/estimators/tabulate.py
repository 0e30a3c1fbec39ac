"""A finished run as one table value: every dataset and attribute, made once, here.

The run hands over its integer state (per direction: the tally planes and statistics
columns its estimator keeps, :data:`~vcavity.estimators.registry` ``TALLIES``/``STATS``,
and the paths traced); the estimator makes each direction's ``brdf``, ``brdf_stderr``,
``albedo``, fold and lost shares; this module adds what every table has (the axes, the
angles, the sensor's cells, the raw counts, the bookkeeping and the run's attributes) and
returns the :class:`vcavity.io.schema.TableValue` the writer checks and stores
(docs/hdf5-format.md). A sweep stores the same values per point.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.estimators.counts import relative_error, table_counts
from vcavity.io.schema import TableValue


def _stat(stats, names, name: str) -> np.ndarray:
    """Column ``name`` of ``stats`` (incidence, len(names)), or zeros where the estimator keeps none."""
    if name in names:
        return np.asarray(stats, dtype=np.int64)[:, list(names).index(name)].copy()
    return np.zeros(len(stats), np.int64)


def tabulate(config, sensor, estimator, tally, stats, paths, models=None, reached=None, *,
             compute_time_s: float = 0.0, compile_time_s: float = 0.0, block_size: int = 0,
             device=None) -> TableValue:
    """The table of a finished run.

    Parameters
    ----------
    config : vcavity.config.RunConfig
    sensor : vcavity.sensor.grid.EqualAreaSensor
    estimator : module
        The run's estimator (:mod:`vcavity.estimators.registry`).
    tally : ndarray of int64 (incidence, len(TALLIES), max_order + 1, cells)
        The run's tally planes per direction (order slot 0: beyond max_order).
    stats : ndarray of int64 (incidence, len(STATS))
    paths : ndarray of int64 (incidence,)
        Paths traced per direction (0 for an estimator that traces none).
    models : object, optional
        The estimator's models (:func:`models`), already refined.
    reached : ndarray of bool (incidence,), optional
        Target-error runs: whether each direction reached the target (else -1 is stored).
    compute_time_s, compile_time_s : float
        Seconds spent tracing (a model's table: computing it) and compiling the walk (the
        models' compile, ``models.compile_time_s``, is their own attribute).
    block_size : int
        Paths per random-number block of the walk.
    device : mapping of str to str, optional
        Where the walk ran, as root attributes: ``{"device": "cpu"}`` (the default), or
        ``"cuda"`` with ``device_name``, ``cuda_driver_version``, ``cuda_runtime_version``
        (:meth:`vcavity.kernels.walks.Walk.device_attributes`).

    Returns
    -------
    vcavity.io.schema.TableValue
    """
    c = config
    n_inc, orders = len(c.incidence), c.orders
    area = np.asarray(sensor.cell_projected_solid_angle, dtype=np.float64)
    shape = (n_inc, len(orders), sensor.n_cells)
    counts, brdf, stderr = np.zeros(shape, np.int64), np.zeros(shape), np.zeros(shape)
    albedo, lost = np.zeros((n_inc, len(orders))), np.zeros((n_inc, 3))
    error, folded = np.full(n_inc, np.nan), np.zeros(n_inc, np.int8)
    for j in range(n_inc):
        if estimator.TALLIES:
            counts[j] = table_counts(tally[j, 0], c.track_all_orders)
        estimate = estimator.estimate(j, tally[j], int(paths[j]), c, sensor, models)
        brdf[j], stderr[j], albedo[j], folded[j] = estimate.brdf, estimate.brdf_stderr, estimate.albedo, estimate.folded
        error[j] = relative_error(estimate, orders, area)
        lost[j] = estimator.lost_fractions(j, stats[j], int(paths[j]), models)
    datasets = {
        "incidence": np.arange(n_inc, dtype=np.int64), "order": np.array(orders, dtype=np.int64),
        "cell": np.arange(sensor.n_cells, dtype=np.int64), "xyz": np.array([b"x", b"y", b"z"], dtype="S1"),
        "theta_i": np.array([d.theta_i for d in c.incidence], dtype=np.float64),
        "phi_i": np.array([d.phi_i for d in c.incidence], dtype=np.float64),
        "theta_i_deg": np.array([d.theta_i_deg for d in c.incidence], dtype=np.float64),
        "phi_i_deg": np.array([d.phi_i_deg for d in c.incidence], dtype=np.float64),
        "theta_o": np.asarray(sensor.cell_theta, dtype=np.float64),
        "phi_o": np.asarray(sensor.cell_phi, dtype=np.float64),
        "brdf": brdf, "brdf_stderr": stderr, "counts": counts,
        "order_source": estimator.order_source(orders), "albedo": albedo,
        "absorbed": lost[:, 0].copy(), "truncated": lost[:, 1].copy(), "degenerate": lost[:, 2].copy(),
        "paths": np.asarray(paths, dtype=np.int64).copy(),
        "unbinned_paths": _stat(stats, estimator.STATS, "unbinned"), "folded": folded,
        "relative_error": error,
        "target_reached": (np.full(n_inc, -1, np.int8) if reached is None
                           else np.asarray(reached, dtype=np.int8).copy()),
        "max_bounces_seen": _stat(stats, estimator.STATS, "max_bounces"),
        "cell_center": np.asarray(sensor.cell_center, dtype=np.float64),
        "cell_solid_angle": np.asarray(sensor.cell_solid_angle, dtype=np.float64),
        "cell_projected_solid_angle": area,
    }
    attrs = {
        "sensor_partition": str(sensor.partition), "sensor_resolution": sensor.resolution,
        "n_cells": sensor.n_cells, "seed": c.seed, "block_size": block_size,
        "max_bounces": c.effective_max_bounces, "config": c.to_dict(),
        "compute_time_s": float(compute_time_s), "compile_time_s": float(compile_time_s),
        "estimator": estimator.NAME,
        "target_error": math.nan if c.target_error is None else float(c.target_error),
        "deterministic": int(estimator.walk(c.material) is None),
        "model_time_s": 0.0 if models is None else float(models.time_s),
        "model_compile_time_s": 0.0 if models is None else float(models.compile_time_s),
        "model_error_ratio": 0.0 if models is None else float(models.error_ratio(tally, paths)),
        **{key: str(value) for key, value in (device or {"device": "cpu"}).items()},
    }
    return TableValue(datasets=datasets, material=c.material.to_dict(), attrs=attrs)


__all__ = ["tabulate"]
