"""Fingerprint the tables of a fixed set of runs (one per distribution x facet mode).

A refactor that must not change results is checked by running this before and after it
(e.g. the old commit in a ``git worktree``, with this script and ``PYTHONPATH`` pointing
at that checkout) and comparing the printed digests: equal digests mean bit-identical
tables for the same config and seed.

    python scripts/fingerprint_counts.py [--paths N] [--json OUT] [--microsurface smith]
        [--estimator analog|paper|exact-f1|exact] [--only SUBSTRING]

Each run goes through the command line (``vcavity run CONFIG -o OUT``, in this process),
the interface every version offers, and its digest is a sha256 over every dataset of the
table (name, dtype, shape, bytes), the ``/material`` attributes and the root attributes
that describe the result (not the creation time, the timings, the version or the config
JSON, which names the output path). ``--microsurface smith`` fingerprints the Smith walk
(the distributions it can walk; the Gaussian's Smith Lambda diverges, so it is left out);
``--estimator exact`` runs the specular facet modes only; ``--extras`` runs a list of other
cases instead of the grid (target errors, f_inf not tracked, no fold, Student-t, conductors).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import sys
import tempfile
from pathlib import Path

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
SPECULAR = ("mirror", "dielectric")
#: Root attributes that change from run to run or name the machine's paths.
VOLATILE = {"created_utc", "compute_time_s", "compile_time_s", "model_time_s", "model_compile_time_s", "vcavity_version",
            "config"}


#: ``--extras``: runs beside the grid (name -> material, [simulation] keys): the stop rule of
#: a target error, f_inf not tracked, no fold, the distributions and facets the grid lacks.
EXTRAS = {
    "target/analog": ({**DISTRIBUTIONS["beckmann"], **FACETS["interfaced"]},
                      {"target_error": 0.02, "max_paths": 400_000}),
    "target/exact-f1": ({**DISTRIBUTIONS["ggx"], **FACETS["lambertian"]},
                        {"estimator": "exact-f1", "target_error": 0.03, "max_paths": 400_000}),
    "target/paper": ({**DISTRIBUTIONS["phong"], **FACETS["interfaced"]},
                     {"estimator": "paper", "target_error": 0.03, "max_paths": 400_000}),
    "target/exact": ({**DISTRIBUTIONS["ggx"], **FACETS["mirror"]}, {"estimator": "exact", "target_error": 0.01}),
    "target/smith": ({**DISTRIBUTIONS["ggx"], **FACETS["interfaced"], "microsurface": "smith"},
                     {"target_error": 0.03, "max_paths": 400_000}),
    "untracked/analog": ({**DISTRIBUTIONS["ggx-aniso"], **FACETS["interfaced"]},
                         {"track_all_orders": False, "max_order": 2}),
    "untracked/exact": ({**DISTRIBUTIONS["beckmann"], **FACETS["dielectric"]},
                        {"estimator": "exact", "track_all_orders": False, "max_order": 2}),
    "untracked/exact-f1": ({**DISTRIBUTIONS["beckmann"], **FACETS["interfaced"]},
                           {"estimator": "exact-f1", "track_all_orders": False, "max_order": 3}),
    "unfolded/paper": ({**DISTRIBUTIONS["ggx"], **FACETS["dielectric"]},
                       {"estimator": "paper", "fold_symmetry": False}),
    "f1-only/analog": ({**DISTRIBUTIONS["phong"], **FACETS["lambertian"]}, {"max_order": 1, "max_bounces": 1,
                                                                            "track_all_orders": False}),
    "student_t/analog": ({"distribution": "student_t", "alpha": 0.4, "gamma": 2.5, **FACETS["interfaced"]}, {}),
    "student_t-aniso/exact-f1": ({"distribution": "student_t", "alpha_x": 0.3, "alpha_y": 0.6, "gamma": 4.0,
                                  **FACETS["lambertian"]}, {"estimator": "exact-f1"}),
    "conductor/analog": ({**DISTRIBUTIONS["beckmann"], "facet": "conductor", "eta": 0.2, "k": 3.0}, {}),
    "conductor/exact": ({**DISTRIBUTIONS["ggx"], "facet": "conductor"}, {"estimator": "exact"}),
    "conductor/smith": ({**DISTRIBUTIONS["beckmann"], "facet": "conductor", "microsurface": "smith"}, {}),
}


def _toml(material: dict, simulation: dict, paths: int | None) -> str:
    """A run config: the fingerprint directions, ``paths`` each (None: no budget, exact)."""
    budget = "" if paths is None else f"paths = {paths}\n"
    return ("[material]\n" + "".join(f"{k} = {json.dumps(v)}\n" for k, v in material.items())
            + "[incidence]\ntheta_i_deg = [0.0, 35.0, 72.5]\nphi_i_deg = [0.0, 20.0, 90.0]\n" + budget
            + "[simulation]\n" + "".join(f"{k} = {json.dumps(v)}\n"
                                        for k, v in {"seed": 7, "max_order": 3, "sensor_resolution": 23,
                                                     **simulation}.items()))


def extras(paths: int):
    """Yield (name, TOML text) of :data:`EXTRAS`."""
    for name, (material, simulation) in EXTRAS.items():
        yield name, _toml(material, simulation, None if simulation.get("estimator") == "exact" else paths)


def configs(paths: int, microsurface: str = "v-cavity", estimator: str = "analog"):
    """Yield (name, TOML text) for every distribution x facet mode of the microsurface."""
    for dname, dist in DISTRIBUTIONS.items():
        if microsurface == "smith" and dname == "gaussian":
            continue
        for fname, facet in FACETS.items():
            if estimator == "exact" and fname not in SPECULAR:
                continue
            material = {**dist, **facet}
            if microsurface != "v-cavity":  # only then: older versions know no microsurface
                material["microsurface"] = microsurface
            simulation = {} if estimator == "analog" else {"estimator": estimator}
            yield f"{dname}/{fname}", _toml(material, simulation, None if estimator == "exact" else paths)


def digest(table_path: Path, skip: frozenset = frozenset()) -> str:
    """sha256 over the table's datasets and result attributes (see the module doc), less the
    root attributes named in ``skip``."""
    import h5py

    h = hashlib.sha256()
    with h5py.File(table_path, "r") as h5:
        for name in sorted(h5.keys()):
            if isinstance(h5[name], h5py.Dataset):
                data = np.ascontiguousarray(h5[name][()])
                h.update(f"{name}|{data.dtype.str}|{data.shape}".encode())
                h.update(data.tobytes())
        for owner, attrs in (("/", h5.attrs), ("/material", h5["material"].attrs)):
            for key in sorted(attrs.keys()):
                if owner == "/" and (key in VOLATILE or key in skip):
                    continue
                h.update(f"{owner}{key}={np.asarray(attrs[key]).tolist()!r}".encode())
    return h.hexdigest()[:16]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=int, default=50_000, help="paths per direction (default 50000)")
    parser.add_argument("--json", help="also write {name: digest} to this file")
    parser.add_argument("--only", help="substring filter on the run names")
    parser.add_argument("--microsurface", default="v-cavity", choices=("v-cavity", "smith"),
                        help="which walk (default v-cavity)")
    parser.add_argument("--estimator", default="analog", choices=("analog", "paper", "exact-f1", "exact"),
                        help="the run's estimator (default analog)")
    parser.add_argument("--extras", action="store_true",
                        help="the runs of EXTRAS instead of the grid (target errors, f_inf not tracked, ...)")
    parser.add_argument("--threads", type=int, default=2, help="threads of each run (default 2)")
    parser.add_argument("--skip-attr", action="append", default=[], metavar="NAME",
                        help="leave this root attribute out of the digests (repeatable): to compare with a "
                             "commit from before the attribute existed, e.g. --skip-attr device")
    args = parser.parse_args(argv)
    from vcavity.cli import main as vcavity_main

    out = {}
    with tempfile.TemporaryDirectory(prefix="vcavity-fingerprint-") as folder:
        runs = extras(args.paths) if args.extras else configs(args.paths, args.microsurface, args.estimator)
        for name, text in runs:
            if args.only and args.only not in name:
                continue
            config = Path(folder) / "run.toml"
            config.write_text(text)
            table = Path(folder) / "run.h5"
            said = io.StringIO()
            with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
                status = vcavity_main(["run", str(config), "-o", str(table), "--overwrite", "-q",
                                       "--threads", str(args.threads)])
            if status != 0:
                print(f"{name}: vcavity run exited {status}:\n{said.getvalue()}", file=sys.stderr)
                return 1
            out[name] = digest(table, frozenset(args.skip_attr))
            print(f"{name:28s} {out[name]}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
