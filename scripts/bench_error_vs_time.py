"""Error against paths and wall time, for every estimator: how fast each reaches a given accuracy.

For each material at theta_i = 60 deg (the IL paper's figure 7(b) material, GGX alpha 0.5
kd 0.8, a near-specular dielectric Beckmann alpha 0.1 kd 0) and each estimator (analog
unfolded = the estimator before the fold existed, analog, exact-f1 and paper, the last
three folded), runs a ladder of path budgets and measures

- the relative L1 error of f1 against the exact cell-averaged V-cavity model,
- the relative L1 errors of f2 and f_inf against a high-budget reference run
  (exact-f1, folded, its own seed; its own noise is printed and subtracted in quadrature),

``L1 = Σ_c |f_c - ref_c| Ω⊥_c / Σ_c ref_c Ω⊥_c``, as functions of paths and of wall time
(tracing plus, for exact-f1, the model's quadrature; compile time excluded). It fits the
log-log slope of error against paths (about -1/2 for an unbiased estimator) and prints each
estimator's efficiency 1 / (error^2 x time) relative to analog unfolded, at the largest
budget. Finally it times an exact-f1 folded run with a target error chosen for 0.2 % L1.

``--specular``: for specular facets (a Beckmann 0.3 mirror, a GGX 0.6 x 0.2 gold conductor)
whole tables at theta_i = 0, 30, 60, 85 deg: the exact estimator at several tolerances and
the analog walk at several budgets, each against an exact table of tolerance 1e-4; the
relative L1 error of f_inf against wall time, and the analog time the same error would
take (from its last point, error ~ time^-1/2).

    python scripts/bench_error_vs_time.py --plot error_vs_time.png       # ~10 min, 2 cores
    python scripts/bench_error_vs_time.py --quick
    python scripts/bench_error_vs_time.py --specular                     # ~3 min
    python scripts/bench_error_vs_time.py --specular --model-only        # the model alone, ~30 s
    python scripts/bench_error_vs_time.py --microsurface smith --quick   # the same on Smith tables

``--microsurface smith`` runs the first part on the Smith microsurface (the estimators it
takes: analog and exact-f1; exact-f1's model is the height-correlated Smith one).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from vcavity import config as config_mod
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import Simulation

MATERIALS = {
    "fig7b (beckmann 0.6, kd 0.9, eta 1.5)": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
    "ggx 0.5, kd 0.8": {"distribution": "ggx", "alpha": 0.5, "kd": 0.8, "eta": 1.5},
    "dielectric (beckmann 0.1, kd 0)": {"distribution": "beckmann", "alpha": 0.1, "kd": 0.0, "eta": 1.5},
}
ESTIMATORS = (("analog, unfolded", "analog", False), ("analog", "analog", None),
              ("exact-f1", "exact-f1", None), ("paper", "paper", None))
THETA_DEG = 60.0


def _config(material, estimator, fold, paths, seed, target=None):
    simulation = {"seed": seed, "max_order": 2, "estimator": estimator, "fold_symmetry": fold}
    if target is not None:
        simulation.update(target_error=target, max_paths=paths)
    return config_mod.validate({"material": material,
                                "incidence": {"theta_i_deg": [THETA_DEG], "paths": paths},
                                "simulation": simulation})


def _run(material, estimator, fold, paths, seed, target=None, repeat=1):
    """The result and the shortest wall time of ``repeat`` identical runs (the table is the
    same each time; the minimum is the least disturbed by other work on the machine)."""
    best = math.inf
    for _ in range(repeat):
        sim = Simulation(_config(material, estimator, fold, paths, seed, target))
        sim.compile()
        start = time.perf_counter()
        result = sim.run()
        best = min(best, time.perf_counter() - start)  # includes the model (exact-f1)
    return result, best


def _l1(values, reference, area):
    return float(np.sum(np.abs(values - reference) * area) / np.sum(reference * area))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="small budgets (a smoke run)")
    parser.add_argument("--plot", metavar="PNG")
    parser.add_argument("--repeat", type=int, default=2, help="runs per point; the shortest time counts (default 2)")
    parser.add_argument("--specular", action="store_true",
                        help="only the specular section: exact against analog on whole tables of a mirror and a "
                        "conductor (theta_i 0, 30, 60, 85 deg)")
    parser.add_argument("--microsurface", choices=("v-cavity", "smith"), default="v-cavity",
                        help="the microsurface of the materials (default v-cavity; smith: analog and exact-f1 only)")
    parser.add_argument("--model-only", action="store_true",
                        help="with --specular: only the every-order model (no simulation), per direction: its mesh, "
                        "seconds and error estimate at tolerances 3e-3 and 1e-3; runs against any tree on "
                        "PYTHONPATH that has vcavity.analytic.specular_orders (an A/B of the model)")
    args = parser.parse_args(argv)
    if args.specular and args.model_only:
        specular_model(args)
        return 0
    if args.specular:
        specular(args)
        return 0
    materials = {name: {**material, "microsurface": args.microsurface} for name, material in MATERIALS.items()}
    estimators = [e for e in ESTIMATORS if args.microsurface == "v-cavity" or e[1] in ("analog", "exact-f1")]
    ladder = [10**5, 4 * 10**5, 16 * 10**5] if args.quick else [10**6, 4 * 10**6, 16 * 10**6, 64 * 10**6]
    reference_paths = 4 * 10**6 if args.quick else 10**9
    print(f"vcavity bench_error_vs_time, {args.microsurface} microsurface, theta_i = {THETA_DEG:g} deg, N = 57, "
          f"{time.strftime('%Y-%m-%d')}")
    curves = {}
    for name, material in materials.items():
        ref, ref_time = _run(material, "exact-f1", None, reference_paths, seed=999)
        area = np.asarray(EqualAreaSensor(57).cell_projected_solid_angle)
        area_sum = {k: np.sum(ref["brdf"][0, k] * area) for k in range(3)}
        ref_noise = {k: math.sqrt(2 / math.pi) * np.sum(ref["brdf_stderr"][0, k] * area) / area_sum[k] for k in (0, 2)}
        f1_model = ref["brdf"][0, 1]  # the exact-f1 reference's model, refined to its 1e9-path tolerance
        print(f"\n{name}: reference {reference_paths:.1e} paths in {ref_time:.1f} s (model {ref.attrs['model_time_s']:.1f} s), "
              f"its expected L1 noise f_inf {ref_noise[0]:.2e}, f2 {ref_noise[2]:.2e}")
        print(f"{'estimator':>18} {'paths':>10} {'time s':>8} {'L1 f1':>9} {'L1 f2':>9} {'L1 f_inf':>9}")
        for label, estimator, fold in estimators:
            rows = []
            for paths in ladder:
                result, seconds = _run(material, estimator, fold, paths, seed=7, repeat=args.repeat)
                errors = [_l1(result["brdf"][0, 1], f1_model, area)]
                for k in (2, 0):  # remove the reference's own noise in quadrature
                    raw = _l1(result["brdf"][0, k], ref["brdf"][0, k], area)
                    errors.append(math.sqrt(max(raw * raw - ref_noise[k] ** 2, 0.25 * raw * raw)))
                rows.append((paths, seconds, *errors))
                shown = "analytic" if estimator == "exact-f1" else f"{errors[0]:9.2e}"
                print(f"{label:>18} {paths:10.1e} {seconds:8.2f} {shown:>9} {errors[1]:9.2e} {errors[2]:9.2e}")
            curves[(name, label)] = np.array(rows)
        base = curves[(name, "analog, unfolded")][-1]
        print(f"{'estimator':>18} {'slope f_inf':>11} {'slope f2':>9} {'efficiency f_inf':>17} {'f2':>6}")
        for label, _, _ in estimators:
            rows = curves[(name, label)]
            slope_inf = np.polyfit(np.log(rows[:, 0]), np.log(rows[:, 4]), 1)[0]
            slope_2 = np.polyfit(np.log(rows[:, 0]), np.log(rows[:, 3]), 1)[0]
            last = rows[-1]
            eff = (base[4] ** 2 * base[1]) / (last[4] ** 2 * last[1])
            eff2 = (base[3] ** 2 * base[1]) / (last[3] ** 2 * last[1])
            print(f"{label:>18} {slope_inf:11.2f} {slope_2:9.2f} {eff:17.1f} {eff2:6.1f}")
    # f_inf to 0.2 % relative L1: with normal cell errors L1 ~ sqrt(2/pi) x the stop rule's error
    material = materials["fig7b (beckmann 0.6, kd 0.9, eta 1.5)"]
    target = 0.002 / math.sqrt(2 / math.pi)
    result, seconds = _run(material, "exact-f1", None, 2 * 10**9, seed=11, target=target)
    ref, _ = _run(material, "exact-f1", None, reference_paths, seed=999)
    area = np.asarray(EqualAreaSensor(57).cell_projected_solid_angle)
    l1 = _l1(result["brdf"][0, 0], ref["brdf"][0, 0], area)
    print(f"\nexact-f1, folded, --target-error {target:.2e} on fig7b at 60 deg: {int(result['paths'][0]):,} paths, "
          f"{seconds:.2f} s wall (model {result.attrs['model_time_s']:.2f} s), L1 of f_inf vs reference {l1:.2e} "
          f"(reference noise included)")
    if args.plot:
        _plot(curves, args.plot, estimators)
        print(f"plot written to {args.plot}")
    return 0


def _plot(curves, path, estimators=ESTIMATORS):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(MATERIALS)
    fig, axes = plt.subplots(2, len(names), figsize=(5 * len(names), 8), constrained_layout=True)
    for column, name in enumerate(names):
        for label, _, _ in estimators:
            rows = curves[(name, label)]
            axes[0, column].loglog(rows[:, 0], rows[:, 4], "o-", label=label)
            axes[1, column].loglog(rows[:, 1], rows[:, 4], "o-", label=label)
        axes[0, column].set_title(name)
        axes[0, column].set_xlabel("paths")
        axes[1, column].set_xlabel("wall time (s), model included")
        for row in (0, 1):
            axes[row, column].set_ylabel("relative L1 error of f_inf")
            axes[row, column].grid(alpha=0.3, which="both")
            axes[row, column].legend(fontsize=8)
    fig.suptitle("vcavity: error of f_inf against paths and wall time, theta_i = 60 deg, 2 threads")
    fig.savefig(path, dpi=110)


# --- specular facets: the exact estimator (every order from the deterministic model) -------------

SPECULAR = {
    "mirror, beckmann 0.3": {"distribution": "beckmann", "alpha": 0.3, "facet": "mirror"},
    "conductor (gold 550 nm), ggx 0.6 x 0.2": {"distribution": "ggx", "alpha_x": 0.6, "alpha_y": 0.2,
                                               "facet": "conductor"},
}
SPECULAR_THETA_DEG = (0.0, 30.0, 60.0, 85.0)


def _specular_config(material, estimator, paths=10**6, tolerance=None, seed=7, phi_deg=0.0):
    simulation = {"seed": seed, "max_order": 3, "estimator": estimator}
    if tolerance is not None:
        simulation["target_error"] = tolerance
    return config_mod.validate({"material": material,
                                "incidence": {"theta_i_deg": list(SPECULAR_THETA_DEG), "phi_i_deg": phi_deg,
                                              "paths": paths},
                                "simulation": simulation})


def _timed(cfg):
    sim = Simulation(cfg)
    sim.compile()
    start = time.perf_counter()
    result = sim.run()
    return result, time.perf_counter() - start


def _table_l1(result, reference, area):
    """Energy-weighted relative L1 of f_inf over the whole table (all directions)."""
    return float(np.sum(np.abs(result["brdf"][:, 0] - reference["brdf"][:, 0]) * area)
                 / np.sum(reference["brdf"][:, 0] * area))


def specular(args) -> dict:
    """Error of f_inf against time for whole tables (theta_i 0, 30, 60, 85 deg), exact vs analog."""
    from vcavity.facet import registry as facets

    tolerances = (1e-2, 3e-3) if args.quick else (1e-2, 3e-3, 1e-3, 3e-4)
    ladder = [10**5, 4 * 10**5] if args.quick else [10**6, 4 * 10**6, 16 * 10**6]
    curves = {}
    for name, material in SPECULAR.items():
        if material["facet"] not in facets.NAMES:
            print(f"\n{name}: facet {material['facet']!r} not in this tree, skipped")
            continue
        phi = 0.0
        reference, ref_time = _timed(_specular_config(material, "exact", tolerance=1e-3 if args.quick else 1e-4))
        area = np.asarray(EqualAreaSensor(57).cell_projected_solid_angle)
        print(f"\n{name}, theta_i {', '.join(f'{t:g}' for t in SPECULAR_THETA_DEG)} deg: reference exact table "
              f"in {ref_time:.1f} s, its relative error estimate {np.nanmax(reference['relative_error']):.1e}")
        print(f"{'estimator':>10} {'setting':>12} {'time s':>8} {'L1 f_inf':>9} {'estimate':>9}")
        rows_exact, rows_analog = [], []
        for tol in tolerances:
            result, seconds = _timed(_specular_config(material, "exact", tolerance=tol))
            l1 = _table_l1(result, reference, area)
            rows_exact.append((tol, seconds, l1))
            print(f"{'exact':>10} {f'tol {tol:.0e}':>12} {seconds:8.2f} {l1:9.2e} "
                  f"{np.nanmax(result['relative_error']):9.2e}")
        for paths in ladder:
            result, seconds = _timed(_specular_config(material, "analog", paths=paths, phi_deg=phi))
            l1 = _table_l1(result, reference, area)
            rows_analog.append((paths, seconds, l1))
            print(f"{'analog':>10} {f'{paths:.1e} paths':>12} {seconds:8.2f} {l1:9.2e}")
        # analog time for an error E, from its last point (error ~ time^-1/2)
        _, t_last, e_last = rows_analog[-1]
        for tol, seconds, l1 in rows_exact:
            analog_time = t_last * (e_last / l1) ** 2
            print(f"   exact at tol {tol:.0e}: L1 {l1:.2e} in {seconds:.2f} s; analog would need ~{analog_time:.3g} s: "
                  f"{analog_time / seconds:.3g}x the efficiency")
        curves[name] = (np.array(rows_exact), np.array(rows_analog))
    return curves


def specular_model(args) -> dict:
    """Seconds of :func:`specular_orders` alone for each table of ``SPECULAR`` (first use
    compiled outside the timing); returns ``{(material, tolerance): seconds}``."""
    import vcavity
    from vcavity.analytic.specular_orders import specular_orders
    from vcavity.facet import registry as facets
    from vcavity.sensor.directions import incident_vector
    from vcavity.sensor.grid import EqualAreaSensor

    print(f"the every-order model of {vcavity.__file__}, theta_i {SPECULAR_THETA_DEG} deg, N = 57, max_order 3")
    sensor = EqualAreaSensor(57)
    totals = {}
    for name, material in SPECULAR.items():
        if material["facet"] not in facets.NAMES:
            continue
        cfg = _specular_config(material, "exact")
        bounces = cfg.effective_max_bounces
        specular_orders(cfg.material, incident_vector(0.3, 0.0), sensor, 3, bounces, tolerance=1.0, start_quads=4)
        for tol in (3e-3, 1e-3):
            total = 0.0
            for theta in SPECULAR_THETA_DEG:
                start = time.perf_counter()
                model = specular_orders(cfg.material, incident_vector(math.radians(theta), 0.0), sensor, 3, bounces,
                                        tolerance=tol)
                seconds = time.perf_counter() - start
                total += seconds
                print(f"{name}, tol {tol:.0e}, theta_i {theta:4.0f}: M {model.quads:5d}, {seconds:6.2f} s, "
                      f"estimate {model.error.sum() / model.exited:.2e}")
            print(f"{name}, tol {tol:.0e}: total {total:.2f} s")
            totals[name, tol] = total
    return totals


if __name__ == "__main__":
    sys.exit(main())
