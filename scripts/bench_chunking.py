#!/usr/bin/env python
"""Calls sized by time against a fixed chunking: throughput and the longest call.

A run's calls are what a Ctrl-C waits for (vcavity/simulate/chunking.py). For each case
(fig. 7b at 60 deg, the V-groove walk's cheapest paths; Smith's walk at GGX alpha = 1000,
the most expensive), the whole pipeline (``Simulation.run``, all threads) runs alternately
with the default sizing and with ``--chunk-blocks 512`` (the fixed default before it), in
one process, the kernel compiled first; printed per case: the median paths per second of
each, their ratio, and the longest call of each (seconds: the worst wait for a Ctrl-C).

    python scripts/bench_chunking.py [--repeat 3] [--fig7b-paths 4e7] [--smith-paths 4e5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from vcavity import config as config_mod
from vcavity.simulate.pipeline import Simulation

CASES = {
    "fig. 7b, 60 deg": {"material": {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian",
                                     "kd": 0.9, "eta": 1.5},
                        "incidence": {"theta_i_deg": [60.0]}, "simulation": {"seed": 1, "max_order": 3}},
    "Smith GGX alpha 1000 mirror, 30 deg": {
        "material": {"microsurface": "smith", "distribution": "ggx", "alpha": 1000.0, "facet": "mirror"},
        "incidence": {"theta_i_deg": [30.0]}, "simulation": {"seed": 1, "max_order": 3, "sensor_resolution": 8}},
}


def timed_run(raw: dict, paths: float, chunk_blocks: int | None) -> tuple[float, float]:
    """Paths per second of one run and its longest call (seconds)."""
    cfg = config_mod.validate({**raw, "incidence": {**raw["incidence"], "paths": paths}})
    simulation = Simulation(cfg, chunk_blocks=chunk_blocks)
    simulation.compile()
    longest = [0.0]
    observe = simulation.chunks.observe

    def watch(n_blocks, seconds):
        longest[0] = max(longest[0], seconds)
        observe(n_blocks, seconds)

    simulation.chunks.observe = watch
    # the longest call is also measured with a fixed size (observe is called, it changes nothing)
    t0 = time.perf_counter()
    simulation.run()
    return paths / (time.perf_counter() - t0), longest[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--fig7b-paths", type=float, default=4e7)
    parser.add_argument("--smith-paths", type=float, default=4e5)
    args = parser.parse_args()
    budgets = [args.fig7b_paths, args.smith_paths]
    print(f"load average {os.getloadavg()[0]:.2f}; {args.repeat} alternated repeats, all threads")
    print(f"{'case':38s} {'paths':>8s} {'timed M/s':>10s} {'fixed 512 M/s':>14s} {'ratio':>6s} "
          f"{'longest call timed':>19s} {'fixed 512':>10s}")
    for (name, raw), paths in zip(CASES.items(), budgets):
        timed, fixed = [], []
        for _ in range(args.repeat):
            timed.append(timed_run(raw, paths, None))
            fixed.append(timed_run(raw, paths, 512))
        rate_timed = statistics.median(r for r, _ in timed)
        rate_fixed = statistics.median(r for r, _ in fixed)
        print(f"{name:38s} {paths:8.0e} {rate_timed / 1e6:10.3f} {rate_fixed / 1e6:14.3f} "
              f"{rate_timed / rate_fixed:6.3f} {max(s for _, s in timed):17.2f} s {max(s for _, s in fixed):8.2f} s")


if __name__ == "__main__":
    main()
