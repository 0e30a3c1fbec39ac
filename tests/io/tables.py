"""Tables made from given integer counts by the analog estimator's formulas, written again.

Tests of the reader, the exports, the plots and the table API need tables with chosen
counts; :func:`analog_table` makes the :class:`vcavity.io.schema.TableValue` that
``write_table`` stores, from counts and path bookkeeping, with plain NumPy
(docs/physics.md sec. 6): ``brdf = counts / (paths Ω⊥_c)``, the binomial standard error
``sqrt(n (1 - n/paths)) / (paths Ω⊥_c)``, ``albedo = Σ_c counts / paths`` and each lost
fraction = its paths / paths. Nothing of vcavity's estimators is used, so it also serves as
an independent reference of the analog estimator (tests/estimators).
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.io.schema import TableValue


def analog_table(*, theta_i, phi_i, order, counts, paths, absorbed_paths, truncated_paths, degenerate_paths,
                 max_bounces_seen, sensor, material, config=None, seed=0, block_size=4096, max_bounces=1000,
                 compute_time_s=0.0, compile_time_s=0.0, theta_i_deg=None, phi_i_deg=None, unbinned_paths=None,
                 tabulated=None, run_attrs=None) -> TableValue:
    """The table of an analog run with these counts (module doc); ``tabulated`` replaces
    datasets by name (another estimator's values), ``run_attrs`` root attributes.

    ``sensor`` is a :class:`vcavity.sensor.grid.EqualAreaSensor` (its cells are the table's).
    """
    theta_i = np.asarray(theta_i, dtype=np.float64)
    phi_i = np.asarray(phi_i, dtype=np.float64)
    order = np.asarray(order, dtype=np.int64)
    counts = np.asarray(counts, dtype=np.int64)
    paths = np.asarray(paths, dtype=np.int64)
    n_i = theta_i.size
    area = np.asarray(sensor.cell_projected_solid_angle, dtype=np.float64)
    paths_f = paths.astype(np.float64)
    counts_f = counts.astype(np.float64)
    denominator = paths_f[:, None, None] * area
    exits = counts.sum(axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        if order[0] == 0:
            n = counts_f[:, 0, :]
            spread = np.sqrt(n * (1.0 - n / paths_f[:, None])).sum(axis=1)
            total = n.sum(axis=1)
            relative_error = np.where(total > 0, spread / np.maximum(total, 1.0), np.inf)
        else:
            relative_error = np.full(n_i, np.nan)
        datasets = {
            "incidence": np.arange(n_i, dtype=np.int64), "order": order,
            "cell": np.arange(sensor.n_cells, dtype=np.int64), "xyz": np.array([b"x", b"y", b"z"], dtype="S1"),
            "theta_i": theta_i, "phi_i": phi_i,
            "theta_i_deg": np.degrees(theta_i) if theta_i_deg is None else np.asarray(theta_i_deg, np.float64),
            "phi_i_deg": np.degrees(phi_i) if phi_i_deg is None else np.asarray(phi_i_deg, np.float64),
            "theta_o": np.asarray(sensor.cell_theta, dtype=np.float64),
            "phi_o": np.asarray(sensor.cell_phi, dtype=np.float64),
            "brdf": counts_f / denominator,
            "brdf_stderr": np.sqrt(counts_f * (1.0 - counts_f / paths_f[:, None, None])) / denominator,
            "counts": counts, "order_source": np.zeros(order.size, np.int8),
            "albedo": exits / paths_f[:, None],
            "absorbed": np.asarray(absorbed_paths) / paths_f,
            "truncated": np.asarray(truncated_paths) / paths_f,
            "degenerate": np.asarray(degenerate_paths) / paths_f,
            "paths": paths,
            "unbinned_paths": (np.zeros(n_i, np.int64) if unbinned_paths is None
                               else np.asarray(unbinned_paths, dtype=np.int64)),
            "folded": np.zeros(n_i, np.int8), "relative_error": relative_error,
            "target_reached": np.full(n_i, -1, np.int8),
            "max_bounces_seen": np.asarray(max_bounces_seen, dtype=np.int64),
            "cell_center": np.asarray(sensor.cell_center, dtype=np.float64),
            "cell_solid_angle": np.asarray(sensor.cell_solid_angle, dtype=np.float64),
            "cell_projected_solid_angle": area,
        }
    for name, array in (tabulated or {}).items():
        datasets[name] = np.asarray(array, dtype=datasets[name].dtype)
    attrs = {"sensor_partition": str(sensor.partition), "sensor_resolution": sensor.resolution,
             "n_cells": sensor.n_cells, "seed": seed, "block_size": block_size, "max_bounces": max_bounces,
             "config": {} if config is None else config, "compute_time_s": float(compute_time_s),
             "compile_time_s": float(compile_time_s), "estimator": "analog", "target_error": math.nan,
             "deterministic": 0}
    attrs.update(run_attrs or {})
    return TableValue(datasets=datasets, material=dict(material), attrs=attrs)


__all__ = ["analog_table"]
