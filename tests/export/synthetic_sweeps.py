"""Sweep files with albedos chosen by the test, written without simulating anything.

A test that checks what an export or a plot does with a sweep's albedo needs a sweep
whose values it knows: :func:`synthetic_sweep` writes one through
:func:`vcavity.io.sweep_table.write_sweep` (the file format, not the code under test),
with the albedo of every grid position and order given by a function of its coordinates.
The sensor is the one-cell sensor (N = 1, the whole hemisphere): albedo consumers do
not read cells, and its ``brdf`` is the albedo over the cell's projected solid angle, as
the reader requires (vcavity.io.checks).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from vcavity.io.sweep_table import GridAxis, SweepData, write_sweep
from vcavity.sensor.grid import EqualAreaSensor

UNITS = {"theta_i_deg": "degree", "phi_i_deg": "degree", "sigma": "rad", "distribution": None}


def synthetic_sweep(path, axes, albedo_of, orders=(0, 1, 2), paths=10_000, estimator="analog",
                    pending=(), material=None, seed=5):
    """Write a sweep file at ``path`` and return its path.

    Parameters
    ----------
    path : path
    axes : sequence of (name, values)
        The grid axes in file order; ``theta_i_deg`` and ``phi_i_deg`` are incidence axes,
        every other one a point axis.
    albedo_of : callable(coords, order) -> float
        The albedo at a grid position (``coords``: axis name -> value) of bounce ``order``.
    orders : sequence of int
        The order axis (0 = f_inf).
    paths : int or callable(coords) -> int
        Paths of each direction.
    estimator : str
        The root attribute ``estimator``.
    pending : sequence of dict
        Points not done (``{"alpha": 0.3}``: every point with alpha = 0.3): NaN albedo,
        0 paths, ``done = 0``.
    material : dict, optional
        ``/material`` (default: beckmann, interfaced_lambertian, kd 0.9, eta 1.5 without
        the swept keys).
    """
    grid = tuple(GridAxis(name, tuple(values), UNITS.get(name, "1"), name) for name, values in axes)
    point_axes = tuple(a.name for a in grid if a.name not in ("theta_i_deg", "phi_i_deg"))
    shared = {"distribution": "beckmann", "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5}
    if material is None:
        material = {k: v for k, v in shared.items() if k not in point_axes}
    sensor = EqualAreaSensor(1)
    cells = {"theta_o": sensor.cell_theta, "phi_o": sensor.cell_phi, "cell_center": sensor.cell_center,
             "cell_solid_angle": sensor.cell_solid_angle,
             "cell_projected_solid_angle": sensor.cell_projected_solid_angle}
    attrs = {"seed": np.uint64(seed), "spec": "{}", "spec_digest": "synthetic", "source": "synthetic.toml",
             "estimator": estimator, "deterministic": np.int64(estimator == "exact"),
             "sensor_resolution": np.int64(1), "n_cells": np.int64(1)}
    scalars = {} if any(a.name == "phi_i_deg" for a in grid) else {"phi_i_deg": 0.0}
    sweep = SweepData(axes=grid, point_axes=point_axes, order=np.array(orders, np.int64), cells=cells,
                      attrs=attrs, material=dict(material), scalars=scalars)
    sweep.allocate()
    for where in itertools.product(*(range(len(a.values)) for a in grid)):
        coords = {a.name: a.values[i] for a, i in zip(grid, where)}
        point = tuple(i for a, i in zip(grid, where) if a.name in point_axes)
        if any(all(coords[k] == v for k, v in p.items()) for p in pending):
            continue
        sweep.data["done"][point] = 1
        sweep.data["paths"][where] = paths(coords) if callable(paths) else paths
        sweep.data["albedo"][where] = [albedo_of(coords, int(k)) for k in orders]
        sweep.data["brdf"][where] = sweep.data["albedo"][where][:, None] / sensor.cell_projected_solid_angle
        sweep.data["brdf_stderr"][where] = 0.0
        for name in ("absorbed", "truncated", "degenerate"):
            sweep.data[name][where] = 0.0
    write_sweep(Path(path), sweep)
    return Path(path)
