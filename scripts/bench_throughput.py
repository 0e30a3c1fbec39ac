#!/usr/bin/env python
"""Throughput of the V-groove walk: paths per second of the kernel, compile time excluded.

Three measurements, printed as tables (docs/performance.md records them):

1. **Against an old commit** (default aae24c0): the old commit is checked out in a
   temporary ``git worktree`` (removed afterwards), and old and new kernels trace the
   figure 7(b) material at theta_i = 60 deg with 2 threads in alternating subprocesses
   (each compiled first, with its own Numba cache); median paths/s of each and the ratio.
   A second pair: the old general kernel against this tree's f1-only walk, both on the
   kd = 0 material (what the f1-only specialisation gained over the unspecialised walk).
2. **Every specialisation** of the current kernel, 1 and 2 threads: the general walk, the
   exact-f1 estimator's binning skip, f1 only, the facet variants, an anisotropic roughness.
3. **The plain-NumPy vectorised walk** (tests/reference/numpy_walk.py) single-threaded, and
   the kernel's single-thread ratio to it: fig. 7b, then every case of 2. against the NumPy
   walk of the same material (which traces every order).

The machine may be shared: the 1-minute load average is printed before each table, and
every rate is given twice, per wall-clock second and per CPU second of the process (all
its threads): on a busy machine the wall-clock rates drop with the share of the cores the
benchmark gets, while paths per CPU second measure the work per path and barely move.
Ratios measured side by side are the figures to trust, not absolute rates.

    python scripts/bench_throughput.py [--paths 2e7] [--repeat 5] [--plot out.png]
    python scripts/bench_throughput.py --skip-baseline --billion   # also time 1e9 paths (2 threads)
    python scripts/bench_throughput.py --smith [--paths 2e6]       # only 4., below

4. (``--smith``, alone) **The Smith walk beside the V-groove walk** on the same materials
   (fig. 7b; GGX 0.5 kd 0.8; GGX 0.5 mirror; Beckmann 0.1 kd 0), 1 and 2 threads, the two
   walks alternated within each repeat: paths per CPU second and their ratio (the cost of a
   Smith path in V-groove paths).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BLOCK = 4096  # rng.BLOCK_SIZE of every version: the untimed compile call traces one block
FIG7B = {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5}

# A child process times the kernel alone through Simulation._call (present, with these
# arguments, in every version since the kernel existed): one call over all blocks.
CHILD = r"""
import json, math, sys, time
spec = json.loads(sys.argv[1])
from vcavity.config import validate
from vcavity.simulate import Simulation, incident_vector
from vcavity.rng import BLOCK_SIZE, direction_key
cfg = validate({"material": spec["material"], "incidence": {"theta_i_deg": [spec["theta"]], "paths": spec["paths"]},
                "simulation": spec.get("simulation", {})})
sim = Simulation(cfg, threads=spec["threads"])
compile_s = sim.compile()
d = cfg.incidence[0]
incident, key = incident_vector(d.theta_i, d.phi_i), direction_key(cfg.seed, d.theta_i, d.phi_i)
rates, cpu = [], []
for _ in range(spec["repeat"]):
    t0, c0 = time.perf_counter(), time.process_time()
    sim._call(incident, key, 0, -(-d.paths // BLOCK_SIZE), d.paths)
    rates.append(d.paths / (time.perf_counter() - t0))
    cpu.append(d.paths / (time.process_time() - c0))
print(json.dumps({"compile_s": compile_s, "rates": rates, "cpu_rates": cpu}))
"""


def _load() -> str:
    return f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores"


def _child(tree: Path, cache: Path, spec: dict) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], env=env, cwd=str(tree),
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"bench_throughput: child in {tree} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


KD0 = {**FIG7B, "kd": 0.0}
F1_ONLY = {"max_order": 1, "track_all_orders": False}
# (key, label, material of the old commit's run, material and simulation table of this tree's)
PAIRS = [
    ("fig7b", "fig. 7b general: old general vs this tree's general", FIG7B, FIG7B, {}),
    ("kd0_f1", "kd = 0: old general vs this tree's f1 only", KD0, KD0, F1_ONLY),
]


def _pair_figures(rates: dict, cpu: dict) -> dict:
    med = {k: statistics.median(v) for k, v in rates.items()}
    cpu_med = {k: statistics.median(v) for k, v in cpu.items()}
    return {"rates": rates, "median": med, "ratio": med["new"] / med["old"],
            "pair_ratios": [n / o for o, n in zip(rates["old"], rates["new"])], "cpu_rates": cpu,
            "cpu_median": cpu_med, "cpu_ratio": cpu_med["new"] / cpu_med["old"]}


def against_commit(commit: str, paths: int, rounds: int, theta: float) -> dict:
    """Median 2-thread paths/s of the old commit and of this tree, alternating subprocesses,
    for each of PAIRS: the fig. 7(b) general kernels (the issue's 1.3x) and the old general
    kernel against this tree's f1-only walk on the kd = 0 material (the specialisation)."""
    with tempfile.TemporaryDirectory(prefix="vcavity-bench-") as tmp:
        tmp = Path(tmp)
        old_tree = tmp / "old"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(old_tree), commit],
                       check=True, capture_output=True, text=True)
        try:
            caches = {"old": tmp / "cache-old", "new": Path(os.environ.get("NUMBA_CACHE_DIR", tmp / "cache-new"))}
            trees = {"old": old_tree, "new": ROOT}
            figures = {"commit": commit, "compile_s": {}}
            for key, label, old_material, new_material, new_simulation in PAIRS:
                specs = {"old": {"material": old_material, "simulation": {}},
                         "new": {"material": new_material, "simulation": new_simulation}}
                for name in ("old", "new"):
                    specs[name].update(theta=theta, paths=paths, threads=2, repeat=1)
                    # compile (or load) once, untimed
                    figures["compile_s"][f"{key}/{name}"] = _child(
                        trees[name], caches[name], {**specs[name], "paths": BLOCK})["compile_s"]
                rates = {"old": [], "new": []}
                cpu = {"old": [], "new": []}
                for r in range(rounds):
                    for name in (("old", "new") if r % 2 == 0 else ("new", "old")):
                        got = _child(trees[name], caches[name], specs[name])
                        rates[name] += got["rates"]
                        cpu[name] += got["cpu_rates"]
                figures[key] = {"label": label, **_pair_figures(rates, cpu)}
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old_tree)],
                           capture_output=True, text=True)
    # the fig. 7(b) pair's figures also at the top level (the plot and older JSON readers)
    return {**figures, **{k: v for k, v in figures["fig7b"].items() if k != "label"}}


# (label, material, simulation table)
CASES = [
    ("fig. 7b IL, general (max_order 3)", FIG7B, {}),
    ("fig. 7b IL, exact-f1 (orders >= 2 binned)", FIG7B, {"estimator": "exact-f1"}),
    ("fig. 7b IL, f1 only", FIG7B, {"max_order": 1, "track_all_orders": False}),
    ("fig. 7b IL, anisotropic alpha 0.6 x 0.3", {**FIG7B, "alpha": None, "alpha_x": 0.6, "alpha_y": 0.3}, {}),
    ("specular dielectric kd = 0, general", {**FIG7B, "kd": 0.0}, {}),
    ("specular dielectric kd = 0, f1 only", {**FIG7B, "kd": 0.0}, {"max_order": 1, "track_all_orders": False}),
    ("Lambertian facets (eta = 1), general", {**FIG7B, "eta": 1.0}, {}),
    ("mirror facets, general", {"distribution": "beckmann", "alpha": 0.6, "facet": "mirror"}, {}),
]


def variants_table(paths: int, repeat: int, theta: float) -> list[dict]:
    """Median paths/s of each case at 1 and 2 threads (kernel calls in this process)."""
    import numba
    import numpy as np

    from vcavity.config import validate
    from vcavity.rng import BLOCK_SIZE, direction_key
    from vcavity.simulate.pipeline import Simulation, incident_vector

    rows = []
    for label, material, simulation in CASES:
        material = {k: v for k, v in material.items() if v is not None}
        cfg = validate({"material": material, "incidence": {"theta_i_deg": [theta], "paths": paths},
                        "simulation": simulation})
        sims = {threads: Simulation(cfg, threads=threads) for threads in (1, 2)}  # the walk as a run calls it
        d = cfg.incidence[0]
        incident, key = incident_vector(d.theta_i, d.phi_i), direction_key(cfg.seed, d.theta_i, d.phi_i)

        def call(n_paths, threads):
            numba.set_num_threads(threads)
            return sims[threads]._call(incident, key, 0, -(-n_paths // BLOCK_SIZE), n_paths)

        t0 = time.perf_counter()
        call(BLOCK_SIZE, 1)
        compile_s = time.perf_counter() - t0
        row = {"label": label, "compile_or_load_s": compile_s}
        for threads in (1, 2):
            rates, cpu = [], []
            for _ in range(repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                tallies, _stats = call(paths, threads)
                rates.append(paths / (time.perf_counter() - t0))
                cpu.append(paths / (time.process_time() - c0))
            row[threads] = statistics.median(rates)
            row[f"cpu{threads}"] = statistics.median(cpu)
        assert np.all(tallies["counts"] >= 0)
        rows.append(row)
        print(f"  {label:44s} {row[1] / 1e6:8.2f} {row[2] / 1e6:8.2f}   {row['cpu1'] / 1e6:8.2f} "
              f"{row['cpu2'] / 1e6:8.2f}   {compile_s:6.1f} s", flush=True)
    return rows


SMITH_CASES = [
    ("fig. 7b (beckmann 0.6, kd 0.9, eta 1.5)", FIG7B),
    ("ggx 0.5, kd 0.8, eta 1.5", {**FIG7B, "distribution": "ggx", "alpha": 0.5, "kd": 0.8}),
    ("ggx 0.5, mirror", {"distribution": "ggx", "alpha": 0.5, "facet": "mirror"}),
    ("beckmann 0.1, kd 0, eta 1.5", {**FIG7B, "alpha": 0.1, "kd": 0.0}),
]


def smith_table(paths: int, repeat: int, theta: float) -> list[dict]:
    """Median paths per wall and per CPU second of each walk on each material, 1 and 2 threads."""
    import numba

    from vcavity.config import validate
    from vcavity.rng import BLOCK_SIZE, direction_key
    from vcavity.simulate.pipeline import Simulation, incident_vector

    rows = []
    for label, material in SMITH_CASES:
        calls = {}
        for surface in ("v-cavity", "smith"):
            cfg = validate({"material": {**material, "microsurface": surface},
                            "incidence": {"theta_i_deg": [theta], "paths": paths}})
            sims = {threads: Simulation(cfg, threads=threads) for threads in (1, 2)}
            d = cfg.incidence[0]
            incident, key = incident_vector(d.theta_i, d.phi_i), direction_key(cfg.seed, d.theta_i, d.phi_i)

            def call(n_paths, threads, sims=sims, incident=incident, key=key):
                numba.set_num_threads(threads)
                return sims[threads]._call(incident, key, 0, -(-n_paths // BLOCK_SIZE), n_paths)

            call(BLOCK_SIZE, 1)  # compile or load
            calls[surface] = call
        row = {"label": label}
        for threads in (1, 2):
            wall = {s: [] for s in calls}
            cpu = {s: [] for s in calls}
            for _ in range(repeat):
                for surface, call in calls.items():  # alternated: both see the same load
                    t0, c0 = time.perf_counter(), time.process_time()
                    call(paths, threads)
                    wall[surface].append(paths / (time.perf_counter() - t0))
                    cpu[surface].append(paths / (time.process_time() - c0))
            for surface in calls:
                row[(surface, threads)] = statistics.median(wall[surface])
                row[(surface, "cpu", threads)] = statistics.median(cpu[surface])
        rows.append(row)
        v, s = row[("v-cavity", "cpu", 1)], row[("smith", "cpu", 1)]
        print(f"  {label:40s} {v / 1e6:7.2f} {s / 1e6:7.2f} {v / s:6.2f}x   "
              f"{row[('v-cavity', 2)] / 1e6:7.2f} {row[('smith', 2)] / 1e6:7.2f} "
              f"{row[('v-cavity', 2)] / row[('smith', 2)]:6.2f}x", flush=True)
    return rows


def numpy_rate(paths: int, theta: float, material: dict = FIG7B) -> tuple[float, float]:
    """Paths per wall-clock and per CPU second of the plain-NumPy walk, single-threaded, every
    order traced (max_order 3), for ``material`` (fig. 7b by default)."""
    sys.path.insert(0, str(ROOT))
    from tests.reference.numpy_walk import walk

    material = {k: v for k, v in material.items() if v is not None}
    walk(material, math.radians(theta), 0.0, 1000, 57, 3)  # warm the Fresnel/quadrature caches
    t0, c0 = time.perf_counter(), time.process_time()
    walk(material, math.radians(theta), 0.0, paths, 57, 3)
    return paths / (time.perf_counter() - t0), paths / (time.process_time() - c0)


def plot(path: str, rows: list[dict], numpy_rates: tuple[float, float], baseline: dict | None) -> None:
    """Two panels of horizontal bars: paths per wall-clock second and per CPU second."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nan = float("nan")
    labels = [r["label"] for r in rows] + ["plain NumPy walk (fig. 7b)"]
    series = {"wall": ([r[1] for r in rows] + [numpy_rates[0]], [r[2] for r in rows] + [nan]),
              "cpu": ([r["cpu1"] for r in rows] + [numpy_rates[1]], [r["cpu2"] for r in rows] + [nan])}
    if baseline:
        labels += [f"fig. 7b general, commit {baseline['commit']}", "fig. 7b general, this tree (same runs)"]
        for key, med in (("wall", "median"), ("cpu", "cpu_median")):
            series[key][0].extend([nan, nan])
            series[key][1].extend([baseline[med]["old"], baseline[med]["new"]])
    y = list(range(len(labels)))
    fig, axes = plt.subplots(1, 2, figsize=(14, 0.45 * len(labels) + 1.8), sharey=True, constrained_layout=True)
    for ax, key, xlabel in zip(axes, ("wall", "cpu"), ("M paths per wall-clock second",
                                                      "M paths per CPU second (all threads)")):
        one, two = series[key]
        ax.barh([v - 0.2 for v in y], [r / 1e6 for r in one], height=0.4, label="1 thread")
        ax.barh([v + 0.2 for v in y], [r / 1e6 for r in two], height=0.4, label="2 threads")
        ax.set_xlabel(xlabel)
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(y, labels)
    axes[0].invert_yaxis()
    axes[1].legend(loc="lower right")
    title = f"vcavity kernel throughput, theta_i = 60 deg, compile excluded ({_load()} at the end)"
    if baseline:
        title += (f"\n{baseline['ratio']:.2f}x commit {baseline['commit']} per wall second, "
                  f"{baseline['cpu_ratio']:.2f}x per CPU second (2 threads, side by side)")
    fig.suptitle(title)
    fig.savefig(path, dpi=100)
    print(f"plot: {path}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=float, default=2e7, help="paths per timed run (default 2e7)")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per variant and thread count (median)")
    parser.add_argument("--rounds", type=int, default=5, help="alternating old/new subprocess pairs (default 5)")
    parser.add_argument("--theta-deg", type=float, default=60.0)
    parser.add_argument("--baseline", default="aae24c0", help="commit to compare against (default aae24c0)")
    parser.add_argument("--skip-baseline", action="store_true", help="skip the comparison with the old commit")
    parser.add_argument("--numpy-paths", type=float, default=2e6, help="paths of the NumPy walk (default 2e6)")
    parser.add_argument("--billion", action="store_true", help="also time 1e9 paths of fig. 7b, 2 threads")
    parser.add_argument("--plot", metavar="PNG", help="write a bar chart of the tables")
    parser.add_argument("--json", metavar="OUT", help="write every figure as JSON")
    parser.add_argument("--smith", action="store_true", help="only the Smith walk beside the V-groove walk (4.)")
    args = parser.parse_args(argv)
    paths = int(args.paths)
    out = {"argv": sys.argv[1:], "date": time.strftime("%Y-%m-%d %H:%M")}
    if args.smith:
        print(f"4. Smith walk beside the V-groove walk, theta_i = {args.theta_deg} deg, {paths:,} paths per run, "
              f"median of {args.repeat} alternated runs ({_load()})")
        print(f"  {'':40s} {'M paths / CPU s, 1 thread':>27s}   {'M paths / wall s, 2 threads':>27s}")
        print(f"  {'material':40s} {'V-cav.':>7s} {'Smith':>7s} {'ratio':>7s}   {'V-cav.':>7s} {'Smith':>7s} "
              f"{'ratio':>7s}")
        rows = smith_table(paths, args.repeat, args.theta_deg)
        if args.json:
            Path(args.json).write_text(json.dumps({**out, "smith": [{str(k): v for k, v in r.items()} for r in rows]},
                                                  indent=1, default=str))
        return 0

    baseline = None
    if not args.skip_baseline:
        print(f"1. theta_i = {args.theta_deg} deg, 2 threads, {paths:,} paths per run; "
              f"commit {args.baseline} vs this tree, {args.rounds} alternating rounds ({_load()})", flush=True)
        baseline = against_commit(args.baseline, paths, args.rounds, args.theta_deg)
        for key, *_ in PAIRS:
            pair = baseline[key]
            print(f"  {pair['label']}")
            for name in ("old", "new"):
                print(f"    {name}: " + " ".join(f"{r / 1e6:.2f}" for r in pair["rates"][name])
                      + f" M/s, median {pair['median'][name] / 1e6:.2f} M/s; per CPU second median "
                      f"{pair['cpu_median'][name] / 1e6:.2f} M/s")
            print(f"    ratio of medians {pair['ratio']:.3f} (per CPU second {pair['cpu_ratio']:.3f}); "
                  "per-round ratios " + " ".join(f"{r:.3f}" for r in pair["pair_ratios"]))
        out["baseline"] = baseline

    print(f"\n2. specialisations, median of {args.repeat} runs of {paths:,} paths ({_load()})")
    print(f"  {'':44s} {'M paths / wall s':>17s}   {'M paths / CPU s':>17s}")
    print(f"  {'case':44s} {'1 thread':>8s} {'2 thr.':>8s}   {'1 thread':>8s} {'2 thr.':>8s}   compile/load")
    rows = variants_table(paths, args.repeat, args.theta_deg)
    out["variants"] = rows
    general = rows[0]
    print(f"  {'ratio to the general fig. 7b kernel':44s} {'2 thr.':>8s} {'per CPU s, 1 thread':>20s}")
    for row in rows[1:]:
        print(f"  {row['label']:44s} {row[2] / general[2]:7.2f}x {row['cpu1'] / general['cpu1']:19.2f}x")
    print(f"  f1 only kd = 0 vs general kd = 0: {rows[5][2] / rows[4][2]:.2f}x (2 threads), "
          f"{rows[5]['cpu1'] / rows[4]['cpu1']:.2f}x (per CPU s, 1 thread)")

    numpy_paths = int(args.numpy_paths)
    print(f"\n3. plain-NumPy walk, fig. 7b, {numpy_paths:,} paths, 1 thread ({_load()})", flush=True)
    np_rate, np_cpu = numpy_rate(numpy_paths, args.theta_deg)
    print(f"  NumPy {np_rate / 1e6:.3f} M/s ({np_cpu / 1e6:.3f} per CPU s); kernel 1 thread "
          f"{general[1] / 1e6:.2f} M/s ({general['cpu1'] / 1e6:.2f} per CPU s): {general[1] / np_rate:.1f}x "
          f"({general['cpu1'] / np_cpu:.1f}x per CPU second)")
    out["numpy"] = {"rate": np_rate, "cpu_rate": np_cpu, "kernel_1_thread": general[1],
                    "ratio": general[1] / np_rate, "cpu_ratio": general["cpu1"] / np_cpu}
    # each case against the NumPy walk of its own material (which traces every order: the
    # f1-only and exact-f1 cases are compared with the walk that does the whole job)
    print(f"  per case, the NumPy walk of the same material ({numpy_paths:,} paths each), 1 thread, per CPU s:")
    numpy_of = {json.dumps(FIG7B, sort_keys=True): np_cpu}
    out["numpy"]["per_case"] = []
    for (label, material, _), row in zip(CASES, rows):
        key = json.dumps(material, sort_keys=True)
        if key not in numpy_of:
            numpy_of[key] = numpy_rate(numpy_paths, args.theta_deg, material)[1]
        print(f"  {label:44s} NumPy {numpy_of[key] / 1e6:6.3f} M/s, kernel {row['cpu1'] / 1e6:6.2f} M/s: "
              f"{row['cpu1'] / numpy_of[key]:5.1f}x", flush=True)
        out["numpy"]["per_case"].append({"label": label, "numpy_cpu_rate": numpy_of[key],
                                         "ratio_cpu": row["cpu1"] / numpy_of[key]})

    seconds = 1e9 / general[2]
    print(f"\n1e9 paths of fig. 7b at 2 threads: {seconds:.1f} s projected from the median rate")
    if args.billion:
        import numba

        from vcavity.config import validate
        from vcavity.simulate.pipeline import Simulation

        numba.set_num_threads(2)
        cfg = validate({"material": FIG7B, "incidence": {"theta_i_deg": [args.theta_deg], "paths": 10**9}})
        sim = Simulation(cfg, threads=2)
        sim.compile()
        t0 = time.perf_counter()
        sim.run()
        seconds = time.perf_counter() - t0
        print(f"  measured (Simulation.run, 1e9 paths): {seconds:.1f} s ({_load()})")
        out["billion_s"] = seconds
    if args.plot:
        plot(args.plot, rows, (np_rate, np_cpu), baseline)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
