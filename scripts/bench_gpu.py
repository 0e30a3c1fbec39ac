#!/usr/bin/env python
"""Paths per second of the walks on a CUDA GPU beside all CPU threads, side by side in one run.

For each config (the IL paper's figure 7(b) material, GGX mirror facets, Smith's walk on
GGX, a gold conductor; theta_i = 60 deg, sensor N = 57, max_order 3) it

- compiles the CUDA kernel (:mod:`vcavity.kernels.cuda_loop`) and reports the compile time
  (the first launch) apart from tracing; a kernel already in vcavity's cache (``vcavity
  warmup --device cuda``, an earlier run) is loaded instead: ``gpu_compiled`` says which,
  and ``NUMBA_CACHE_DIR`` pointing at an empty folder times a cold compile,
- times ``--gpu-paths`` paths on the GPU (one launch, one thread per RNG block; the median of
  ``--repeat`` launches after a warm-up launch) and ``--cpu-paths`` paths with the CPU walk on
  all cores (``vcavity.simulate.pipeline.Simulation``, compiled or loaded from the cache first),
- prints paths/s of both and their ratio, and the largest |z| between the two targets'
  per-order albedos (a sanity check, not a test: tests/kernels/test_cuda_loop.py has those).

Without numba-cuda, without a CUDA device, or under the CUDA simulator it prints one line
saying so and exits with status 0 (there is nothing to time).

    python scripts/bench_gpu.py                        # 1e9 GPU paths, 2e7 CPU paths per config
    python scripts/bench_gpu.py --gpu-paths 1e8 --json gpu.json

docs/performance.md ("The walks on a GPU") records the figures.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FIG7B = {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5}
#: (label, [material] table): the configs issue 37 names.
CONFIGS = [
    ("fig. 7b (Beckmann 0.6, IL kd 0.9, eta 1.5)", FIG7B),
    ("GGX 0.5, mirror", {"distribution": "ggx", "alpha": 0.5, "facet": "mirror"}),
    ("Smith walk, GGX 0.5, IL kd 0.8", {"distribution": "ggx", "alpha": 0.5, "facet": "interfaced_lambertian",
                                        "kd": 0.8, "eta": 1.5, "microsurface": "smith"}),
    ("GGX 0.3, gold conductor", {"distribution": "ggx", "alpha": 0.3, "facet": "conductor"}),
]


def no_gpu_reason() -> str | None:
    """Why nothing can be timed here (one line), or None when a CUDA device is present."""
    try:
        from vcavity.kernels import cuda_loop
    except ImportError as error:
        return f"no GPU to time: {error}"
    if cuda_loop.SIMULATED:
        return "no GPU to time: NUMBA_ENABLE_CUDASIM=1 runs the CUDA simulator, which is not a GPU"
    from numba import cuda

    if not cuda.is_available():
        return "no GPU to time: numba-cuda finds no CUDA device or driver"
    return None


def device_line() -> str:
    """The device's name, compute capability and driver/runtime versions."""
    from numba import cuda

    device = cuda.get_current_device()
    name = device.name.decode() if isinstance(device.name, bytes) else str(device.name)
    try:
        driver = cuda.cudadrv.driver.driver.get_version()
    except Exception:  # the version query differs between numba-cuda releases: informational only
        driver = "?"
    try:
        runtime = cuda.runtime.get_version()
    except Exception:
        runtime = "?"
    return f"{name}, compute capability {device.compute_capability}, driver {driver}, runtime {runtime}"


def albedo_z(gpu_counts, gpu_paths: int, cpu_counts, cpu_paths: int) -> float:
    """Largest |z| over order slots between the two targets' albedo fractions (binomial errors)."""
    worst = 0.0
    for g, c in zip(gpu_counts.sum(axis=1), cpu_counts.sum(axis=1)):
        p_g, p_c = g / gpu_paths, c / cpu_paths
        var = p_g * (1 - p_g) / gpu_paths + p_c * (1 - p_c) / cpu_paths
        if var > 0:
            worst = max(worst, abs(p_g - p_c) / math.sqrt(var))
    return worst


def bench_config(label: str, material: dict, args) -> dict:
    """One config's CPU and GPU rates, compile times and albedo agreement (both targets are
    called as a run calls them: ``Simulation._call``, the GPU's with ``device = "cuda"``)."""
    import numba
    import numpy as np

    from vcavity.config import validate
    from vcavity.rng import BLOCK_SIZE, direction_key
    from vcavity.simulate.pipeline import Simulation, incident_vector

    table = {"material": material, "incidence": {"theta_i_deg": [args.theta_deg], "paths": 10**6}}
    threads = numba.config.NUMBA_NUM_THREADS
    cpu = Simulation(validate(table), threads=threads)
    gpu = Simulation(validate({**table, "simulation": {"device": "cuda"}}))
    d = cpu.config.incidence[0]
    incident, key = incident_vector(d.theta_i, d.phi_i), direction_key(cpu.config.seed, d.theta_i, d.phi_i)
    row = {"label": label, "cpu_threads": threads, "cpu_compile_or_load_s": cpu.compile()}

    cpu_paths = int(args.cpu_paths)
    rates = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        cpu_tallies, _ = cpu._call(incident, key, 0, -(-cpu_paths // BLOCK_SIZE), cpu_paths)
        rates.append(cpu_paths / (time.perf_counter() - t0))
    row["cpu_rate"] = statistics.median(rates)

    compiles = gpu.kernel.compiles
    row["gpu_compile_s"] = gpu.compile()  # a compile, or a load from vcavity's cache (module doc)
    row["gpu_compiled"] = gpu.kernel.compiles > compiles
    gpu_paths = int(args.gpu_paths)
    # the GPU's blocks start after the CPU's: two independent samples for the albedo z
    after = -(-cpu_paths // BLOCK_SIZE)
    n_blocks, total = -(-gpu_paths // BLOCK_SIZE), after * BLOCK_SIZE + gpu_paths
    warm = min(64, n_blocks)
    gpu._call(incident, key, after, warm, (after + warm) * BLOCK_SIZE)  # warm-up: module load, allocations
    rates = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        gpu_tallies, gpu_stats = gpu._call(incident, key, after, n_blocks, total)  # copied back: finished
        rates.append(gpu_paths / (time.perf_counter() - t0))
    row["gpu_rate"] = statistics.median(rates)
    row["ratio"] = row["gpu_rate"] / row["cpu_rate"]
    row["albedo_max_abs_z"] = albedo_z(gpu_tallies["counts"], gpu_paths, cpu_tallies["counts"], cpu_paths)
    assert np.all(gpu_tallies["counts"] >= 0) and all(v >= 0 for v in gpu_stats.values())
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gpu-paths", type=float, default=1e9, help="paths per timed GPU launch (default 1e9)")
    parser.add_argument("--cpu-paths", type=float, default=2e7, help="paths per timed CPU call (default 2e7)")
    parser.add_argument("--repeat", type=int, default=3, help="timed calls per target and config (median)")
    parser.add_argument("--theta-deg", type=float, default=60.0)
    parser.add_argument("--json", metavar="OUT", help="also write every figure as JSON")
    args = parser.parse_args(argv)
    reason = no_gpu_reason()
    if reason is not None:
        print(reason)
        return 0
    print(f"vcavity bench_gpu, {time.strftime('%Y-%m-%d %H:%M')}; GPU: {device_line()}; CPU: {os.cpu_count()} "
          f"cores; theta_i = {args.theta_deg} deg, N = 57, max_order 3; GPU {args.gpu_paths:.0e} paths, CPU "
          f"{args.cpu_paths:.0e} paths, median of {args.repeat}", flush=True)
    print(f"  {'config':42s} {'GPU M/s':>9s} {'CPU M/s':>9s} {'GPU/CPU':>8s} {'GPU compile s':>14s} "
          f"{'albedo |z|':>10s}")
    rows = []
    for label, material in CONFIGS:
        row = bench_config(label, material, args)
        rows.append(row)
        print(f"  {label:42s} {row['gpu_rate'] / 1e6:9.1f} {row['cpu_rate'] / 1e6:9.2f} {row['ratio']:7.1f}x "
              f"{row['gpu_compile_s']:13.1f}{' ' if row['gpu_compiled'] else '*'} {row['albedo_max_abs_z']:10.2f}",
              flush=True)
    if not all(row["gpu_compiled"] for row in rows):
        print("  * loaded from vcavity's cache, not compiled (NUMBA_CACHE_DIR=<an empty folder> times a compile)")
    if args.json:
        Path(args.json).write_text(json.dumps({"argv": sys.argv[1:], "device": device_line(), "rows": rows},
                                              indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
