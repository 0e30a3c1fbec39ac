#!/usr/bin/env python
"""Sweep file I/O per finished point against the number of points (issue 20).

For each ``--points`` N this builds a synthetic sweep (one alpha axis of N points x
``--directions`` incident directions, orders 0..3, an N_s x N_s sensor) whose values are
random but consistent, as finished points would leave them (no tracing: I/O only), and
times, in a folder of ``--dir`` (a real disk: fsync matters):

- ``create``: the first point's write, the whole file (``write_sweep``: every dataset
  allocated and contiguous, NaN / 0 for the points not done);
- ``commit``: each later point committed in place (``PointWriter.commit``: its values,
  fsync, checksum and done flag, fsync), for up to ``--commits`` points spread over the
  grid; median and mean per point;
- ``old``: the whole-file rewrite every point cost before, at commit e091c4d (gzip-chunked
  ``brdf``, ``brdf_stderr``, ``counts``), the module loaded from git (``git show``), with
  half of the points done; median of ``--old-repeat`` (skipped when git cannot show it).

``--compute`` also times the tracing of one point at default budgets (10^7 paths per
direction, N_s = 57, orders 0..3, beckmann alpha 0.5 + interfaced Lambertian) over the
same directions, compile time excluded, for the "under 5 % of a point" target.

    python scripts/bench_sweep_io.py                                  # N = 10, 100, 1000; N_s = 15
    python scripts/bench_sweep_io.py --points 10 100 --resolution 57 --compute
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

import numpy as np

from vcavity.io.atomic import write_hdf5
from vcavity.io.sweep_points import PointWriter
from vcavity.io.sweep_table import GridAxis, SweepData, write_sweep
from vcavity.sensor.grid import EqualAreaSensor

OLD_COMMIT = "e091c4d"


def synthetic(points: int, directions: int, resolution: int) -> tuple[SweepData, dict]:
    """The sweep before any point is done, and the values of every point when done."""
    sensor = EqualAreaSensor(resolution)
    area = sensor.cell_projected_solid_angle
    theta = tuple(float(t) for t in np.linspace(0.0, 80.0, directions))
    axes = (GridAxis("alpha", tuple(float(a) for a in np.linspace(0.05, 1.0, points))),
            GridAxis("theta_i_deg", theta, "degree"))
    cells = {"theta_o": sensor.cell_theta, "phi_o": sensor.cell_phi, "cell_center": sensor.cell_center,
             "cell_solid_angle": sensor.cell_solid_angle, "cell_projected_solid_angle": area}
    attrs = {"seed": np.uint64(1), "spec": "{}", "spec_digest": "bench", "source": "bench_sweep_io.py",
             "estimator": "analog", "sensor_resolution": np.int64(resolution), "n_cells": np.int64(sensor.n_cells),
             "overrides": "{}"}
    sweep = SweepData(axes=axes, point_axes=("alpha",), order=np.arange(4), cells=cells, attrs=attrs,
                      material={"distribution": "beckmann", "facet": "interfaced_lambertian"},
                      scalars={"phi_i_deg": 0.0})
    sweep.allocate()
    rng = np.random.default_rng(1)
    paths = 10_000_000
    counts = rng.integers(0, 20_000, sweep.data["counts"].shape)
    done = {"counts": counts, "brdf": counts / (paths * area), "brdf_stderr": np.sqrt(counts) / (paths * area),
            "albedo": counts.sum(axis=-1) / paths, "paths": np.full(sweep.shape, paths),
            "absorbed": np.full(sweep.shape, 0.01), "relative_error": np.full(sweep.shape, 0.01),
            "seed": rng.integers(0, 2**63, points).astype(np.uint64),
            "compute_time_s": np.full(points, 5.0)}
    return sweep, done


def finish(sweep: SweepData, done: dict, point: int) -> None:
    """Record point ``point`` as a finished run would (values, done flag)."""
    for name, values in done.items():
        sweep.data[name][point] = values[point]
    sweep.data["done"][point] = 1


def old_writer():
    """``write_sweep`` as of :data:`OLD_COMMIT` (the whole-file rewrite), or None."""
    try:
        source = subprocess.run(["git", "show", f"{OLD_COMMIT}:vcavity/io/sweep_table.py"], capture_output=True,
                                text=True, check=True, cwd=Path(__file__).resolve().parent).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    module = types.ModuleType("sweep_table_" + OLD_COMMIT)
    sys.modules[module.__name__] = module  # dataclasses look their module up
    exec(compile(source, f"{OLD_COMMIT}:vcavity/io/sweep_table.py", "exec"), module.__dict__)
    return lambda path, sweep: write_hdf5(path, lambda h5: module._fill(h5, sweep), track_order=True)


def measure(points: int, args, old) -> dict:
    sweep, done = synthetic(points, args.directions, args.resolution)
    row = {"points": points}
    with tempfile.TemporaryDirectory(dir=args.dir) as folder:
        path = Path(folder) / "bench.h5"
        finish(sweep, done, 0)
        t0 = time.perf_counter()
        write_sweep(path, sweep)
        row["create_s"] = time.perf_counter() - t0
        row["size_mb"] = path.stat().st_size / 1e6
        chosen = np.unique(np.linspace(1, points - 1, min(args.commits, points - 1)).round().astype(int))
        times = []
        with PointWriter(path, sweep) as writer:
            for point in chosen:
                finish(sweep, done, int(point))
                t0 = time.perf_counter()
                writer.commit((int(point),))
                times.append(time.perf_counter() - t0)
        row["commit_median_ms"] = 1e3 * statistics.median(times)
        row["commit_mean_ms"] = 1e3 * statistics.fmean(times)
        row["commits"] = len(times)
        if old is not None:
            for point in range(points // 2):
                finish(sweep, done, point)
            for point in range(points // 2, points):  # half done: NaN compresses better than values
                sweep.data["done"][point] = 0
            repeats = []
            for _ in range(args.old_repeat):
                t0 = time.perf_counter()
                old(Path(folder) / "old.h5", sweep)
                repeats.append(time.perf_counter() - t0)
            row["old_ms"] = 1e3 * statistics.median(repeats)
            row["old_size_mb"] = (Path(folder) / "old.h5").stat().st_size / 1e6
    return row


def compute_seconds(directions: int) -> float:
    """Wall seconds tracing one point at default budgets (compile and warm-up excluded)."""
    from vcavity import config as config_mod
    from vcavity.simulate.pipeline import simulate

    theta = [float(t) for t in np.linspace(0.0, 80.0, directions)]
    raw = {"material": {"distribution": "beckmann", "alpha": 0.5, "kd": 0.9, "eta": 1.5},
           "incidence": {"theta_i_deg": theta}, "simulation": {"seed": 1}}
    warm = dict(raw, incidence={"theta_i_deg": theta[:1], "paths": 4096})
    simulate(config_mod.validate(warm))
    t0 = time.perf_counter()
    simulate(config_mod.validate(raw))
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--directions", type=int, default=11)
    parser.add_argument("--resolution", type=int, default=15, help="sensor N_s (N_s x N_s cells)")
    parser.add_argument("--commits", type=int, default=100, help="points committed in place per N (at most)")
    parser.add_argument("--old-repeat", type=int, default=2, help="whole-file rewrites timed per N (0: none)")
    parser.add_argument("--dir", default=".", help="folder for the files (a real disk)")
    parser.add_argument("--compute", action="store_true", help="also time one point's tracing at default budgets")
    args = parser.parse_args()
    old = old_writer() if args.old_repeat > 0 else None
    print(f"{args.directions} directions per point, orders 0..3, {args.resolution} x {args.resolution} cells; "
          f"old: {'write_sweep of ' + OLD_COMMIT if old else 'not measured'}")
    print(f"{'points':>7} {'file MB':>8} {'create s':>9} {'commit ms (median / mean, n)':>30} "
          f"{'old rewrite ms':>15} {'old file MB':>12}")
    for points in args.points:
        row = measure(points, args, old)
        old_text = (f"{row['old_ms']:15.0f} {row['old_size_mb']:12.1f}" if "old_ms" in row else "")
        print(f"{row['points']:7d} {row['size_mb']:8.1f} {row['create_s']:9.2f} "
              f"{row['commit_median_ms']:14.2f} / {row['commit_mean_ms']:6.2f}, {row['commits']:4d} {old_text}",
              flush=True)
    if args.compute:
        seconds = compute_seconds(args.directions)
        print(f"compute of one point at default budgets ({args.directions} directions x 1e7 paths, 57 x 57 cells, "
              f"orders 0..3): {seconds:.2f} s")


if __name__ == "__main__":
    main()
