"""Inputs of the ``--kind versus`` tests, written without simulating: tables of random
counts (:func:`random_table`) and a sweep file of random values with a real sensor
(:func:`random_sweep`). The tests read the expected numbers back with h5py or xarray,
not with vcavity's readers.
"""

from __future__ import annotations

import itertools

import numpy as np

from vcavity.io.sweep_table import GridAxis, SweepData, write_sweep
from vcavity.io.table import write_table
from tests.io.tables import analog_table
from vcavity.sensor.grid import EqualAreaSensor

MATERIAL = {"distribution": "beckmann", "alpha_x": 0.5, "alpha_y": 0.5, "facet": "interfaced_lambertian",
            "kd": 0.9, "eta": 1.5}


def random_table(path, theta_deg, seed, material=MATERIAL, resolution=9, orders=(0, 1, 2, 3), phi_deg=0.0):
    """A table of random integer counts: per direction its own number of paths, per order
    and cell Poisson counts (f_inf = the sum of the orders plus more), so every number
    (brdf, stderr, albedo) differs between directions, orders, cells and tables."""
    rng = np.random.default_rng(seed)
    sensor = EqualAreaSensor(resolution)
    theta_deg = np.asarray(theta_deg, dtype=np.float64)
    phi = np.broadcast_to(np.asarray(phi_deg, dtype=np.float64), theta_deg.shape)
    n = theta_deg.size
    paths = rng.integers(200_000, 400_000, size=n)
    counts = np.zeros((n, len(orders), sensor.n_cells), dtype=np.int64)
    scale = {1: 100.0, 2: 30.0, 3: 5.0}
    for j in range(n):
        by_order = {k: rng.poisson(scale[k] * rng.uniform(0.5, 1.5, sensor.n_cells)) for k in scale}
        rest = rng.poisson(2.0, sensor.n_cells)
        for slot, k in enumerate(orders):
            counts[j, slot] = by_order[k] if k else sum(by_order.values()) + rest
    exits = counts[:, list(orders).index(0)].sum(axis=1)
    zeros = np.zeros(n, dtype=np.int64)
    write_table(path, analog_table(theta_i=np.radians(theta_deg), phi_i=np.radians(phi), order=list(orders), counts=counts,
                paths=paths, absorbed_paths=paths - exits, truncated_paths=zeros, degenerate_paths=zeros,
                max_bounces_seen=zeros + 5, sensor=sensor, material=dict(material), config={}, seed=seed,
                block_size=1, max_bounces=100, theta_i_deg=theta_deg, phi_i_deg=phi))
    return path


def random_sweep(path, axes, seed=3, resolution=9, orders=(0, 1, 2), pending=()):
    """A sweep file (analog) whose brdf, brdf_stderr and paths are random at every grid
    position (albedo: the sum of brdf x projected solid angle); ``axes`` are ``(name, values)`` in file order; ``pending`` lists points
    (``{"alpha": 0.3, ...}``) left not done."""
    rng = np.random.default_rng(seed)
    sensor = EqualAreaSensor(resolution)
    units = {"theta_i_deg": "degree", "phi_i_deg": "degree", "microsurface": None}
    grid = tuple(GridAxis(name, tuple(values), units.get(name, "1"), name) for name, values in axes)
    point_axes = tuple(a.name for a in grid if a.name not in ("theta_i_deg", "phi_i_deg"))
    material = {k: v for k, v in MATERIAL.items() if k not in point_axes and k not in ("alpha_x", "alpha_y")}
    cells = {"theta_o": sensor.cell_theta, "phi_o": sensor.cell_phi, "cell_center": sensor.cell_center,
             "cell_solid_angle": sensor.cell_solid_angle,
             "cell_projected_solid_angle": sensor.cell_projected_solid_angle}
    attrs = {"seed": np.uint64(seed), "spec": "{}", "spec_digest": "synthetic", "source": "synthetic.toml",
             "estimator": "analog", "sensor_resolution": np.int64(resolution), "n_cells": np.int64(sensor.n_cells),
             "sensor_partition": sensor.partition}
    scalars = {} if any(a.name == "phi_i_deg" for a in grid) else {"phi_i_deg": 0.0}
    sweep = SweepData(axes=grid, point_axes=point_axes, order=np.array(orders, np.int64), cells=cells,
                      attrs=attrs, material=material, scalars=scalars)
    sweep.allocate()
    for where in itertools.product(*(range(len(a.values)) for a in grid)):
        coords = {a.name: a.values[i] for a, i in zip(grid, where)}
        if any(all(coords[k] == v for k, v in p.items()) for p in pending):
            continue
        sweep.data["done"][tuple(i for a, i in zip(grid, where) if a.name in point_axes)] = 1
        sweep.data["paths"][where] = rng.integers(100_000, 300_000)
        brdf = rng.uniform(0.0, 1.0, (len(orders), sensor.n_cells)) * rng.uniform(0.01, 0.3, (len(orders), 1))
        sweep.data["brdf"][where] = brdf
        # the albedo a sweep stores is the sum of brdf x projected solid angle (open_sweep checks it)
        sweep.data["albedo"][where] = brdf @ sensor.cell_projected_solid_angle
        sweep.data["brdf_stderr"][where] = rng.uniform(0.001, 0.01, (len(orders), sensor.n_cells))
        for name in ("absorbed", "truncated", "degenerate"):
            sweep.data[name][where] = 0.0
    write_sweep(path, sweep)
    return path
