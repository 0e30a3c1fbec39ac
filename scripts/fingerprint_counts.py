"""Fingerprint the integer counts of a fixed set of runs (one per distribution x facet mode).

A refactor that must not change results is checked by running this before and after it
(e.g. on the old commit in a ``git worktree``) and comparing the printed digests: equal
digests mean bit-identical ``counts`` and path statistics for the same config and seed.

    python scripts/fingerprint_counts.py [--paths N] [--json OUT] [--microsurface smith]

``--microsurface smith`` fingerprints the Smith walk instead (the distributions it can walk;
the Gaussian's Smith Lambda diverges, so it is left out).

Uses only ``vcavity.config.validate`` and ``vcavity.simulate.simulate``, which every
version of the package since 0.1.0 offers.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

import numpy as np

DISTRIBUTIONS = {
    "beckmann": {"distribution": "beckmann", "alpha": 0.6},
    "beckmann-aniso": {"distribution": "beckmann", "alpha_x": 0.2, "alpha_y": 0.7},
    "ggx": {"distribution": "ggx", "alpha": 0.5},
    "ggx-aniso": {"distribution": "ggx", "alpha_x": 0.8, "alpha_y": 0.15},
    "phong": {"distribution": "phong", "exponent": 12.0},
    "gaussian": {"distribution": "gaussian", "sigma": 0.35},
}
FACETS = {
    "mirror": {"facet": "mirror"},
    "dielectric": {"facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5},
    "lambertian": {"facet": "interfaced_lambertian", "kd": 0.7, "eta": 1.0},
    "interfaced": {"facet": "interfaced_lambertian", "kd": 0.8, "eta": 1.5},
}


def configs(paths: int, microsurface: str = "v-cavity"):
    """Yield (name, raw config dict) for every distribution x facet mode of the microsurface."""
    for dname, dist in DISTRIBUTIONS.items():
        if microsurface == "smith" and dname == "gaussian":
            continue
        for fname, facet in FACETS.items():
            # the key is given only for the Smith walk: older versions know no microsurface
            surface = {} if microsurface == "v-cavity" else {"microsurface": microsurface}
            yield f"{dname}/{fname}", {
                "material": {**dist, **facet, **surface},
                "incidence": {"theta_i_deg": [0.0, 35.0, 72.5], "phi_i_deg": [0.0, 20.0, 90.0],
                              "paths": paths},
                "simulation": {"seed": 7, "max_order": 3, "sensor_resolution": 23},
            }


def digest(result) -> str:
    """sha256 over counts and per-direction path statistics (int64, C order)."""
    h = hashlib.sha256()
    for name in ("counts", "paths", "absorbed_paths", "truncated_paths", "degenerate_paths",
                 "max_bounces_seen"):
        h.update(np.ascontiguousarray(getattr(result, name), dtype=np.int64).tobytes())
    return h.hexdigest()[:16]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=int, default=50_000, help="paths per direction (default 50000)")
    parser.add_argument("--json", help="also write {name: digest} to this file")
    parser.add_argument("--only", help="substring filter on the run names")
    parser.add_argument("--microsurface", default="v-cavity", choices=("v-cavity", "smith"),
                        help="which walk (default v-cavity)")
    args = parser.parse_args(argv)
    from vcavity.config import validate
    from vcavity.simulate import simulate

    out = {}
    for name, raw in configs(args.paths, args.microsurface):
        if args.only and args.only not in name:
            continue
        result = simulate(validate(raw))
        out[name] = digest(result)
        print(f"{name:28s} {out[name]}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
