#!/usr/bin/env python
"""A/B of the walks' cost per path between two checkouts: CPU ns a path, 1 thread, alternated.

For changes to the kernels that must not cost throughput (docs/performance.md records the
figures). Each child process builds one material's kernel from one checkout (``PYTHONPATH``),
compiles it untimed (a Numba cache per side under ``/tmp``), then times ``REPEAT`` kernel calls
of ``PATHS`` paths at theta_i = 60 deg on one Numba thread and reports the least CPU time per
path. Sides alternate A, B / B, A by round, so drift of the machine falls on both. One
thread and CPU time: two threads on a two-core machine swing by ~10 % from run to run.
Also prints whether both sides' counts sum alike (a cheap check; fingerprint_counts.py is the
full one).

    python scripts/bench_walk_ab.py TREE_A TREE_B [PATHS] [REPEAT] [ROUNDS] [--smith | --paper]

e.g. ``python scripts/bench_walk_ab.py . /tmp/wt-main 1e6 5 3`` (a worktree of the commit
to compare with). Materials: fig. 7b (Beckmann 0.6, kd 0.9, eta 1.5), its Lambertian
(eta 1) and specular-dielectric (kd 0) limits, GGX 0.5 kd 0.8; ``--smith``: the same on the
Smith microsurface; ``--paper``: the paper estimator's weighted kernel.
"""
import json
import os
import subprocess
import sys

CHILD = r"""
import json, sys, time
spec = json.loads(sys.argv[1])
from vcavity.config import validate
from vcavity.simulate import Simulation, incident_vector
from vcavity.rng import BLOCK_SIZE, direction_key
cfg = validate({"material": spec["material"], "incidence": {"theta_i_deg": [60.0], "paths": spec["paths"]}, **({"simulation": {"estimator": "paper"}} if spec.get("paper") else {})})
sim = Simulation(cfg, threads=1)
sim.compile()
d = cfg.incidence[0]
incident, key = incident_vector(d.theta_i, d.phi_i), direction_key(cfg.seed, d.theta_i, d.phi_i)
best = []
for _ in range(spec["repeat"]):
    c0 = time.process_time()
    out = sim._call(incident, key, 0, -(-d.paths // BLOCK_SIZE), d.paths)
    best.append((time.process_time() - c0) / d.paths * 1e9)
import numpy as np
counts = out[0]["counts"] if isinstance(out[0], dict) else out[0]  # named tallies since the one walk loop
print(json.dumps({"ns": min(best), "sum": int(np.asarray(counts).sum())}))
"""
positional = [arg for arg in sys.argv[1:] if not arg.startswith("--")]
if len(positional) < 2:
    sys.exit(__doc__)
a, b = os.path.abspath(positional[0]), os.path.abspath(positional[1])
paths, repeat, rounds = (int(float(x)) for x in (positional[2:] + ["1e6", "5", "3"][len(positional) - 2:])[:3])
smith = "--smith" in sys.argv
M = {
 "fig7b IL": {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.5},
 "lambertian": {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.9, "eta": 1.0},
 "dielectric": {"distribution": "beckmann", "alpha": 0.6, "facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5},
 "ggx IL .8": {"distribution": "ggx", "alpha": 0.5, "facet": "interfaced_lambertian", "kd": 0.8, "eta": 1.5},
}
if smith:
    for m in M.values(): m["microsurface"] = "smith"
res = {k: {"A": [], "B": []} for k in M}
for r in range(rounds):
    for name in M:
        for side in (("A", "B") if r % 2 == 0 else ("B", "A")):
            tree = a if side == "A" else b
            env = dict(os.environ, PYTHONPATH=tree, NUMBA_CACHE_DIR=f"/tmp/vcavity-bench-ab-{side}", NUMBA_NUM_THREADS="1")
            out = subprocess.run([sys.executable, "-c", CHILD, json.dumps({"material": M[name], "paths": paths, "repeat": repeat, "paper": "--paper" in sys.argv})],
                                 env=env, cwd=tree, capture_output=True, text=True)
            if out.returncode:
                sys.exit(out.stderr[-2000:])
            res[name][side].append(json.loads(out.stdout.strip().splitlines()[-1]))
    print(f"round {r}: load {os.getloadavg()[0]:.2f}", flush=True)
for name, d in res.items():
    na = [x["ns"] for x in d["A"]]; nb = [x["ns"] for x in d["B"]]
    same = {x["sum"] for x in d["A"]} == {x["sum"] for x in d["B"]}
    print(f"{name:12s} A {min(na):6.1f} ({' '.join(f'{x:.1f}' for x in na)})  B {min(nb):6.1f} ({' '.join(f'{x:.1f}' for x in nb)})  A/B min {min(na)/min(nb):.3f}  median {sorted(na)[len(na)//2]/sorted(nb)[len(nb)//2]:.3f}  sums equal {same}")
