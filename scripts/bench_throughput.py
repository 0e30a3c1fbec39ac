#!/usr/bin/env python
"""Throughput of the V-groove walk: paths per second, compile time excluded.

Prints, for a specular dielectric, the IL paper's figure 7(b) material and Lambertian
facets, the paths/s with 1 and 2 threads, the parallel efficiency, and the peak RSS
growth between a short and a long run (memory must not grow with the path count).

    python scripts/bench_throughput.py [--paths N] [--theta-deg 60] [--repeat 3]
"""

from __future__ import annotations

import argparse
import resource
import time

import numba

from vcavity.config import validate
from vcavity.simulate import Simulation

MATERIALS = {
    "specular dielectric (kd=0, eta=1.5)": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.0, "eta": 1.5},
    "figure 7b IL (kd=0.9, eta=1.5)": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
    "Lambertian (kd=0.9, eta=1)": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.0},
}


def _rate(material, theta_deg, paths, threads, repeat):
    cfg = validate({"material": material, "incidence": {"theta_i_deg": [theta_deg], "paths": paths}})
    sim = Simulation(cfg, threads=threads)
    compile_s = sim.compile()
    best = 0.0
    for _ in range(repeat):
        t0 = time.perf_counter()
        sim.run()
        best = max(best, paths / (time.perf_counter() - t0))
    return best, compile_s


def _peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--paths", type=int, default=20_000_000, help="paths per timed run (default 2e7)")
    parser.add_argument("--theta-deg", type=float, default=60.0)
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per case; the best is kept")
    args = parser.parse_args()
    cores = numba.config.NUMBA_NUM_THREADS
    print(f"numba {numba.__version__}, {cores} cores, theta_i = {args.theta_deg} deg, {args.paths:,} paths/run, best of {args.repeat}")
    print(f"{'material':40s} {'1 thread':>14s} {f'{cores} threads':>14s} {'efficiency':>10s} {'compile/load':>12s}")
    for name, material in MATERIALS.items():
        r1, c1 = _rate(material, args.theta_deg, args.paths, 1, args.repeat)
        rn, _ = _rate(material, args.theta_deg, args.paths, cores, args.repeat)
        print(f"{name:40s} {r1 / 1e6:10.2f} M/s {rn / 1e6:10.2f} M/s {rn / (cores * r1):10.1%} {c1:10.2f} s", flush=True)
    # memory: a 10x longer run must not raise the peak RSS
    mat = MATERIALS["figure 7b IL (kd=0.9, eta=1.5)"]
    _rate(mat, args.theta_deg, args.paths // 10, cores, 1)
    before = _peak_rss_mb()
    _rate(mat, args.theta_deg, args.paths * 2, cores, 1)
    after = _peak_rss_mb()
    print(f"peak RSS after {args.paths // 10:,} paths: {before:.1f} MB; after {args.paths * 2:,} paths: {after:.1f} MB "
          f"(growth {after - before:+.1f} MB)")


if __name__ == "__main__":
    main()
