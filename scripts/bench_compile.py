#!/usr/bin/env python
"""Cold compile and warm load of the kernel variants and of the models ``vcavity compare`` uses.

Every measurement is a child process with a fresh, empty ``NUMBA_CACHE_DIR`` (cold: Numba
compiles everything the target needs, shared helpers included), then a second child on
the cache the first one filled (warm: what a later run pays). A child reports wall and
CPU seconds and, from Numba's event API (``numba.core.event``: ``numba:run_pass`` and
``numba:llvm_lock`` events), the time of each compiler pass, exclusive of the passes of
the functions it compiles along the way (a callee is compiled inside its caller's type
inference), and the time spent holding the LLVM lock (LLVM's optimisation and machine code).

Targets:

- ``kernel``: ``Simulation(config).compile()`` for a material that selects one variant
  (``--variant beckmann/interfaced_lambertian/full``; ``--all-variants`` for every one);
- ``compare``: ``vcavity compare`` on a small table, cold minus nothing: the whole command
  with an empty cache, so the analytic single-bounce models and the cell averages compile
  (the table is written first, once per checkout, with a cache of its own).

``--baseline PATH`` runs the same children with ``PYTHONPATH=PATH`` (another checkout, e.g.
a worktree of commit 3ec0f6e), alternating A, B, A, B, ..., and prints the ratio of the
medians (A / B). The machine may be shared: the load average is printed, and CPU seconds
move much less with load than wall seconds.

    python scripts/bench_compile.py [--repeat 2] [--target kernel compare] [--passes 12]
    python scripts/bench_compile.py --baseline /tmp/wt-3ec0f6e --target kernel
    python scripts/bench_compile.py --all-variants --repeat 1 --target kernel
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# facet variant -> the facet parameters that select it (the kernel's facet variants)
FACET_VALUES = {
    ("interfaced_lambertian", "full"): {"kd": 0.9, "eta": 1.5},
    ("interfaced_lambertian", "specular_dielectric"): {"kd": 0.0, "eta": 1.5},
    ("interfaced_lambertian", "lambertian"): {"kd": 0.9, "eta": 1.0},
    ("mirror", "full"): {},
    ("conductor", "full"): {"eta": 0.43, "k": 2.455},
}
DISTRIBUTION_VALUES = {"beckmann": {"alpha": 0.6}, "ggx": {"alpha": 0.5}, "phong": {"exponent": 20.0},
                       "gaussian": {"sigma": 0.3}, "student_t": {"alpha": 0.5, "gamma": 2.0}}

# The child: listeners on Numba's events, then the target. Simulation and validate have
# these names and arguments in every version since the kernel existed.
CHILD = r"""
import json, sys, time
from numba.core import event
spec = json.loads(sys.argv[1])
passes, stack, lock = {}, [], [0.0]

class Passes(event.Listener):
    def on_start(self, ev):
        stack.append([time.perf_counter(), 0.0])
    def on_end(self, ev):
        start, nested = stack.pop()
        spent = time.perf_counter() - start
        passes[ev.data["name"]] = passes.get(ev.data["name"], 0.0) + spent - nested
        if stack:
            stack[-1][1] += spent

class Lock(event.Listener):
    def on_start(self, ev):
        self.t = time.perf_counter()
    def on_end(self, ev):
        lock[0] += time.perf_counter() - self.t

event.register("numba:run_pass", Passes())
event.register("numba:llvm_lock", Lock())
t0, c0 = time.perf_counter(), time.process_time()
if spec["target"] == "kernel":
    from vcavity.config import validate
    from vcavity.simulate import Simulation
    cfg = validate({"material": spec["material"], "incidence": {"theta_i_deg": [30], "paths": 4096}})
    t1, c1 = time.perf_counter(), time.process_time()
    Simulation(cfg, threads=1).compile()
else:
    from vcavity.cli import main
    t1, c1 = time.perf_counter(), time.process_time()
    status = main(["compare", spec["table"]])
    assert status in (0, 1), status
print(json.dumps({"wall": time.perf_counter() - t1, "cpu": time.process_time() - c1,
                  "import_wall": t1 - t0, "passes": passes, "llvm_lock": lock[0]}))
"""


def _child(checkout: Path, cache: Path, spec: dict) -> dict:
    env = dict(os.environ, PYTHONPATH=str(checkout), NUMBA_CACHE_DIR=str(cache))
    done = subprocess.run([sys.executable, "-c", CHILD, json.dumps(spec)], env=env, capture_output=True,
                          text=True, timeout=3600, cwd=cache.parent)
    if done.returncode != 0:
        raise SystemExit(f"child failed ({checkout}, {spec}):\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _table(checkout: Path, work: Path) -> str:
    """A small default-material table written by ``checkout`` (its own cache, kept apart)."""
    out = work / f"table-{abs(hash(str(checkout)))}.h5"
    if not out.exists():
        env = dict(os.environ, PYTHONPATH=str(checkout), NUMBA_CACHE_DIR=str(work / f"nc-table-{out.stem}"))
        subprocess.run([sys.executable, "-m", "vcavity", "run", "-o", str(out), "--paths", "1e5", "-q"],
                       env=env, check=True, capture_output=True, timeout=3600, cwd=work)
    return str(out)


def measure(checkout: Path, spec: dict, work: Path, n: int) -> dict:
    """One cold and one warm child of ``spec`` in a fresh cache folder."""
    cache = work / f"nc-{n}"
    shutil.rmtree(cache, ignore_errors=True)
    cache.mkdir()
    if spec["target"] == "compare":
        spec = dict(spec, table=_table(checkout, work))
    cold = _child(checkout, cache, spec)
    warm = _child(checkout, cache, spec)
    shutil.rmtree(cache, ignore_errors=True)
    return {"cold": cold, "warm": warm}


def _material(variant: str) -> dict:
    dist, facet, which = variant.split("/")
    return {"distribution": dist, **DISTRIBUTION_VALUES[dist], "facet": facet, **FACET_VALUES[(facet, which)]}


def _load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def _print_passes(label: str, runs: list[dict], top: int) -> None:
    total = {}
    for run in runs:
        for name, seconds in run["cold"]["passes"].items():
            total[name] = total.get(name, 0.0) + seconds / len(runs)
    lock = statistics.mean(run["cold"]["llvm_lock"] for run in runs)
    wall = statistics.mean(run["cold"]["wall"] for run in runs)
    print(f"\n{label}: compiler passes, exclusive wall seconds (mean of {len(runs)}; cold wall {wall:.1f} s)")
    for name, seconds in sorted(total.items(), key=lambda kv: -kv[1])[:top]:
        print(f"  {name:<40s} {seconds:7.2f}  {100 * seconds / wall:5.1f} %")
    print(f"  {'(sum of all passes)':<40s} {sum(total.values()):7.2f}")
    print(f"  {'of which: LLVM lock held':<40s} {lock:7.2f}  {100 * lock / wall:5.1f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--target", nargs="+", choices=("kernel", "compare"), default=["kernel", "compare"])
    parser.add_argument("--variant", nargs="+", default=["beckmann/interfaced_lambertian/full"],
                        help="DIST/FACET/VARIANT, VARIANT one of full, specular_dielectric, lambertian")
    parser.add_argument("--all-variants", action="store_true", help="every distribution x facet variant")
    parser.add_argument("--repeat", type=int, default=2, help="cold+warm pairs per checkout and target")
    parser.add_argument("--baseline", type=Path, help="another checkout, measured alternately (A/B)")
    parser.add_argument("--passes", type=int, default=10, help="how many passes to list")
    parser.add_argument("--work", type=Path, help="folder for caches and tables (default: a temporary one)")
    args = parser.parse_args()
    variants = ([f"{d}/{f}/{v}" for d in DISTRIBUTION_VALUES for f, v in FACET_VALUES] if args.all_variants
                else args.variant)
    for variant in variants:
        _material(variant)  # unknown names fail before anything runs
    work = args.work or Path(tempfile.mkdtemp(prefix="bench-compile-"))
    work.mkdir(parents=True, exist_ok=True)
    sides = [("A", ROOT)] + ([("B", args.baseline.resolve())] if args.baseline else [])
    print(f"# bench_compile: A = {ROOT}" + (f", B = {sides[1][1]}" if args.baseline else "") +
          f"; python {sys.version.split()[0]}; {os.cpu_count()} cores; {_load()}")
    specs = [(f"kernel {v}", {"target": "kernel", "material": _material(v)}) for v in variants
             if "kernel" in args.target]
    specs += [("compare (analytic models)", {"target": "compare"})] if "compare" in args.target else []
    n = 0
    for label, spec in specs:
        runs = {side: [] for side, _ in sides}
        for _ in range(args.repeat):
            for side, checkout in sides:  # alternated: A, B, A, B, ...
                runs[side].append(measure(checkout, spec, work, n))
                n += 1
        print(f"\n{label}  ({_load()})")
        print(f"  {'':4s} {'cold wall s':>12s} {'cold CPU s':>11s} {'warm wall s':>12s} {'warm CPU s':>11s} "
              f"{'import s':>9s}")
        med = {}
        for side, _ in sides:
            r = runs[side]
            med[side] = {"cold wall": statistics.median(x["cold"]["wall"] for x in r),
                         "cold cpu": statistics.median(x["cold"]["cpu"] for x in r),
                         "warm wall": statistics.median(x["warm"]["wall"] for x in r),
                         "warm cpu": statistics.median(x["warm"]["cpu"] for x in r),
                         "import": statistics.median(x["cold"]["import_wall"] for x in r)}
            each = ", ".join(f"{x['cold']['cpu']:.1f}" for x in r)
            print(f"  {side:4s} {med[side]['cold wall']:12.2f} {med[side]['cold cpu']:11.2f} "
                  f"{med[side]['warm wall']:12.3f} {med[side]['warm cpu']:11.3f} {med[side]['import']:9.2f}   "
                  f"(cold CPU each: {each})")
        if args.baseline:
            print(f"  A/B  {med['A']['cold wall'] / med['B']['cold wall']:11.3f} "
                  f"{med['A']['cold cpu'] / med['B']['cold cpu']:11.3f} "
                  f"{med['A']['warm wall'] / med['B']['warm wall']:12.3f} "
                  f"{med['A']['warm cpu'] / med['B']['warm cpu']:11.3f}")
        for side, _ in sides:
            _print_passes(f"{label} [{side}]", runs[side], args.passes)
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
