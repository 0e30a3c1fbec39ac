#!/usr/bin/env python
"""Time to read a sweep file, and the share of it the read-time checks take.

``open_sweep`` checks what it reads (vcavity/io/checks.py: finite, non-negative values,
albedo against brdf x projected solid angle, flags, orders, angles, sensor geometry) and
verifies each done point's checksum (vcavity/io/sweep_checksum.py).
This writes a synthetic sweep of ``--points`` points (one alpha axis) x ``--directions``
incident directions, every point done, with random but consistent values on an
N x N sensor, then times (median of ``--repeat``) the whole ``open_sweep``, the checks
alone (``check_sweep`` on the data already in memory) and the checksums alone. Plain NumPy, nothing compiled.

    python scripts/bench_read.py                       # 1000 points x 11 directions, N = 15, orders 0..3
    python scripts/bench_read.py --resolution 57 --points 100
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from vcavity.io import checks, sweep_checksum
from vcavity.io.sweep_table import RADIANS, GridAxis, SweepData, open_sweep, write_sweep
from vcavity.sensor.grid import EqualAreaSensor


def synthetic(path: Path, points: int, directions: int, resolution: int, max_order: int) -> int:
    """Write the benchmark's sweep file; returns its size in bytes."""
    sensor = EqualAreaSensor(resolution)
    area = sensor.cell_projected_solid_angle
    theta = tuple(float(t) for t in np.linspace(0.0, 80.0, directions))
    axes = (GridAxis("alpha", tuple(float(a) for a in np.linspace(0.05, 1.0, points))),
            GridAxis("theta_i_deg", theta, "degree"))
    cells = {"theta_o": sensor.cell_theta, "phi_o": sensor.cell_phi, "cell_center": sensor.cell_center,
             "cell_solid_angle": sensor.cell_solid_angle, "cell_projected_solid_angle": area}
    attrs = {"seed": np.uint64(1), "spec": "{}", "spec_digest": "bench", "source": "bench_read.py",
             "estimator": "analog", "sensor_resolution": np.int64(resolution), "n_cells": np.int64(sensor.n_cells)}
    sweep = SweepData(axes=axes, point_axes=("alpha",), order=np.arange(max_order + 1), cells=cells, attrs=attrs,
                      material={"distribution": "beckmann", "facet": "interfaced_lambertian"},
                      scalars={"phi_i_deg": 0.0})
    sweep.allocate()
    rng = np.random.default_rng(1)
    paths = 1_000_000
    counts = rng.integers(0, 200, sweep.data["counts"].shape)
    sweep.data["counts"][...] = counts
    sweep.data["brdf"][...] = counts / (paths * area)
    sweep.data["brdf_stderr"][...] = np.sqrt(counts) / (paths * area)
    sweep.data["albedo"][...] = counts.sum(axis=-1) / paths
    for name in ("absorbed", "truncated", "degenerate", "relative_error"):
        sweep.data[name][...] = 0.01
    sweep.data["paths"][...] = paths
    sweep.data["done"][...] = 1
    write_sweep(path, sweep)
    return path.stat().st_size


def _median_seconds(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        function()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--directions", type=int, default=11)
    parser.add_argument("--resolution", type=int, default=15, help="sensor N (N x N cells)")
    parser.add_argument("--max-order", type=int, default=3)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.h5"
        size = synthetic(path, args.points, args.directions, args.resolution, args.max_order)
        sweep = open_sweep(path)
        import h5py

        with h5py.File(path, "r") as h5:
            radians = {name: h5[name][()] for name in RADIANS.values() if name in h5}
        whole = _median_seconds(lambda: open_sweep(path), args.repeat)
        checked = _median_seconds(lambda: checks.check_sweep(sweep, radians, str(path)), args.repeat)
        dims = {name: sweep.dims(name) for name in sweep.data}
        summed = _median_seconds(lambda: sweep_checksum.verified(sweep.data, dims, sweep.point_axes,
                                                                 sweep.data["done"], sweep.data["checksum"]),
                                 args.repeat)
    n_values = sweep.data["brdf"].size
    print(f"sweep file: {args.points} points x {args.directions} directions, {args.max_order + 1} orders, "
          f"{args.resolution}x{args.resolution} cells: {n_values:,} brdf values, {size / 1e6:.1f} MB "
          f"(load {os.getloadavg()[0]:.2f})")
    print(f"open_sweep: {whole:.3f} s (median of {args.repeat}); checks alone: {checked:.3f} s "
          f"({100 * checked / whole:.0f} % of the read); per-point checksums alone: {summed:.3f} s "
          f"({100 * summed / whole:.0f} %)")


if __name__ == "__main__":
    main()
