"""Plant known bugs in copies of the package and check that the default test suite catches each.

    python scripts/mutation_check.py                 # every mutant, default suite each
    python scripts/mutation_check.py --list          # the mutants and the tests meant to catch them
    python scripts/mutation_check.py --only solid-angle-x2 --only beyond-k-as-k
    python scripts/mutation_check.py --quick         # only the catching tests (a fast smoke run)

For each mutant the repository's tracked files (``git ls-files``) are copied to a
temporary folder, one exact source edit is applied (an edit whose text no longer
appears exactly once is reported as STALE: update this list after refactors), and the
default suite (``python -m pytest -x -q``, i.e. without ``slow`` tests) runs on the copy
with a fresh ``NUMBA_CACHE_DIR`` and ``PYTHONPATH`` pointing at the copy. The tests meant
to catch the mutant run first, then the whole default suite, so a caught mutant usually
stops early. A mutant is CAUGHT when pytest reports failures (exit status 1), SURVIVED
when the suite passes (exit 0), and ERROR otherwise (collection or usage errors: the
mutation broke imports, which proves nothing about the tests).

Exit status: 0 when every mutant was caught, 1 otherwise. The list below is the one
documented in docs/validation.md ("Planted bugs").
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Mutant:
    """One planted bug: replace ``old`` (which must occur exactly once) by ``new`` in ``path``."""

    name: str
    path: str
    old: str
    new: str
    what: str
    caught_by: tuple[str, ...]


MUTANTS = (
    Mutant("groove-counts-swapped-at-boundary", "vcavity/analytic/specular_groove.py",
           "pieces = ((j_lo, x_break + 1.0), (j_hi, x_hi - x_break))",
           "pieces = ((j_hi, x_break + 1.0), (j_lo, x_hi - x_break))",
           "the two bounce counts of one side credited to each other's entry interval (n - 1 / n boundary)",
           ("tests/analytic/test_specular_groove.py",)),
    Mutant("groove-one-reflectance-too-few", "vcavity/analytic/specular_groove.py",
           "log_short = _log_survival(0.0, 1, n_short,",
           "log_short = _log_survival(0.0, 2, n_short,",
           "the survival product skips the first hit's reflectance",
           ("tests/analytic/test_specular_groove.py",)),
    Mutant("groove-longer-count-misses-a-hit", "vcavity/analytic/specular_groove.py",
           "log_long = _log_survival(log_short, n_short + 1,",
           "log_long = _log_survival(log_short, n_short + 2,",
           "the longer of a side's two bounce counts continues the shorter one's survival one hit too late",
           ("tests/analytic/test_specular_groove.py",)),
    Mutant("visible-ggx-squeeze-flipped", "vcavity/microfacet/ggx.py",
           "s = 0.5 * (1.0 + hz)",
           "s = 0.5 * (1.0 - hz)",
           "the GGX visible-normal sampler squeezes the projected disk by (1 - v_z)/2 instead of (1 + v_z)/2",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("visible-beckmann-across-slope-widened", "vcavity/microfacet/beckmann.py",
           "    y = visible.normal_quantile(u2)",
           "    y = 1.1 * visible.normal_quantile(u2)",
           "the Beckmann visible-normal sampler draws the slope across the view 10 % too wide",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("visible-student-t-across-slope-unscaled", "vcavity/microfacet/student_t.py",
           "y = math.hypot(math.sqrt(z), x) * (a / math.sqrt(zc))",
           "y = math.sqrt(z) * (a / math.sqrt(zc))",
           "the Student-t visible-normal sampler forgets that the slope across widens with the slope along",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("visible-student-t-along-cdf-sign", "vcavity/microfacet/student_t_tails.py",
           "return mu * (1.0 - tail) + (partial + x * tail)",
           "return mu * (1.0 - tail) + (partial - x * tail)",
           "the Student-t visible slope's CDF subtracts x P(q < x) where it adds it (x >= 0)",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("smith-height-exponent-off", "vcavity/kernels/smith.py",
           "log_c += log_s / (1.0 + lam_v)",
           "log_c += log_s / (2.0 + lam_v)",
           "the Smith walk's downward height CDF has its exponent 1 + Lambda off by one",
           ("tests/kernels/test_smith_walk.py",)),
    Mutant("smith-escape-inverted", "vcavity/kernels/smith.py",
           "            if log_s < lam * log_c:",
           "            if log_s >= lam * log_c:",
           "the Smith walk's escape test of an upward ray inverted (where its Lambda bound left it open)",
           ("tests/kernels/test_smith_walk.py::test_white_facets_lose_nothing",)),
    Mutant("smith-escape-bound-inverted", "vcavity/kernels/smith.py",
           "            if log_s < bound * log_c:",
           "            if log_s >= bound * log_c:",
           "the Smith walk's escape test of an upward ray by its Lambda bound inverted",
           ("tests/kernels/test_smith_walk.py::test_white_facets_lose_nothing",)),
    Mutant("smith-lambda-wrong-direction", "vcavity/kernels/smith.py",
           "lam = distributions.smith_lambda_past_bound(dist_kind, bound, wx, wy, wz, params)",
           "lam = distributions.smith_lambda_past_bound(dist_kind, bound, wy, wx, wz, params)",
           "the Smith walk's Lambda of an upward ray taken for the direction with x and y swapped",
           ("tests/kernels/test_smith_walk.py",)),
    Mutant("smith-facet-frame-sign", "vcavity/kernels/smith.py",
           "        dy = cos_p * wy - sin_p * wx",
           "        dy = cos_p * wy + sin_p * wx",
           "the Smith walk's facet frame turned with a sign error",
           ("tests/kernels/test_smith_walk.py",)),
    Mutant("smith-normals-from-d", "vcavity/kernels/smith.py",
           "state, mx, my, mz = distributions.sample_visible_stream(dist_kind, state, -wx, -wy, -wz, lam_v, params)",
           "mx, my, mz = distributions.sample_normal(dist_kind, -math.expm1(-standard_exponential(state)[1]), "
           "-math.expm1(-standard_exponential(standard_exponential(state)[0])[1]), params)",
           "the Smith walk draws facet normals from D(m)(m.n) instead of the visible normals",
           ("tests/kernels/test_smith_walk.py",)),
    Mutant("smith-rehit-height-exponent", "vcavity/kernels/smith.py",
           "log_c -= log_s / lam",
           "log_c -= 0.5 * log_s / lam",
           "the Smith walk's height of a hit by an upward ray drawn with the exponent 1/(2 Lambda) (orders >= 2 only)",
           ("tests/kernels/test_smith_reference.py",)),
    Mutant("smith-first-lambda-reused", "vcavity/kernels/smith.py",
           "lam_v = lam_i if k == 0 else distributions.smith_lambda(dist_kind, -wx, -wy, -wz, params)",
           "lam_v = lam_i",
           "the Smith walk's later downward steps use the first hit's Lambda(i) instead of the ray's own",
           ("tests/kernels/test_smith_reference.py",)),
    Mutant("smith-sampler-first-lambda", "vcavity/kernels/smith.py",
           "state, -wx, -wy, -wz, lam_v, params)",
           "state, -wx, -wy, -wz, lam_i, params)",
           "the Smith walk's visible-normal sampler (Beckmann's mixture weights) gets the first hit's Lambda(i)",
           ("tests/kernels/test_smith_reference.py::test_kernel_agrees_with_the_numpy_smith_walk[beckmann1.0-mirror-0-0]",)),
    Mutant("visible-beckmann-stream-across-widened", "vcavity/microfacet/beckmann.py",
           "    y *= _INV_SQRT2\n",
           "    y *= 1.1 * _INV_SQRT2\n",
           "the Smith walk's Beckmann sampler draws the slope across the view 10 % too wide",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("visible-ggx-stream-disk-overshoot", "vcavity/microfacet/ggx.py",
           "if p1 * p1 + p2 * p2 < 1.0:",
           "if p1 * p1 + p2 * p2 < 1.2:",
           "the Smith walk's GGX sampler keeps square points outside the unit disk",
           ("tests/microfacet/test_visible_normals.py",)),
    Mutant("ziggurat-normal-wedge-accepts", "vcavity/rng/ziggurat.py",
           "if lower + u * (_NORMAL_HEIGHT[i + 1] - lower) < math.exp(-0.5 * x * x):",
           "if True:",
           "the ziggurat keeps every normal draw in a layer's wedge, under the curve or not",
           ("tests/rng/test_ziggurat.py",)),
    Mutant("ziggurat-normal-tail-unrejected", "vcavity/rng/ziggurat.py",
           "if -2.0 * math.log(1.0 - u2) > t * t:",
           "if True:",
           "the ziggurat's normal tail keeps r + t without Marsaglia's rejection",
           ("tests/rng/test_ziggurat.py",)),
    Mutant("orders-out-of-plane-dropped", "vcavity/analytic/specular_orders.py",
           "u, v = hemisphere_to_square(ex * cos_phi - dy * sin_phi, ex * sin_phi + dy * cos_phi,",
           "u, v = hemisphere_to_square(ex * cos_phi, ex * sin_phi,",
           "the every-order model's exit direction loses its component along the groove",
           ("tests/analytic/test_specular_orders.py",)),
    Mutant("orders-tau-weights-swapped", "vcavity/analytic/specular_orders.py",
           "return mass - hi, hi",
           "return hi, mass - hi",
           "the every-order model's hat weights against du1/dtau credited to the wrong end of each interval",
           ("tests/analytic/test_specular_orders.py",)),
    Mutant("orders-density-corners-swapped", "vcavity/analytic/splat.py",
           "((1.0 - l1 - l2) * m0 + l1 * m1 + l2 * m2)",
           "((1.0 - l1 - l2) * m0 + l2 * m1 + l1 * m2)",
           "the every-order model's linear density over an image triangle takes two corners' values swapped",
           ("tests/analytic/test_specular_orders.py",)),
    Mutant("block-binning-no-exact-pass", "vcavity/sensor/binning.py",
           "        if cells[j] < 0:",
           "        if cells[j] < -10**18:",
           "exits near a bin edge keep the fast atan's (flagged) bin instead of being re-binned exactly",
           ("tests/sensor/test_binning.py",)),
    Mutant("ordered-sum-drops-tail", "vcavity/analytic/single_bounce.py",
           "    while k < n:\n        p0 += terms[k]\n        k += 1",
           "    while k < n:\n        k += 1",
           "the body row sum drops the last n mod 8 terms",
           ("tests/analytic/test_single_bounce.py",)),
    Mutant("f1-refinement-too-loose", "vcavity/estimators/exact_f1.py",
           "                model.refine_to(tolerance)",
           "                model.refine_to(tolerance * 3)",
           "exact-f1's post-run model refined to 0.3 instead of 0.1 of the statistical error",
           ("tests/estimators/test_exact_f1.py",)),
    Mutant("fresnel-macro-cosine", "vcavity/facet/interfaced_lambertian.py",
           "        reflected = _below_fresnel(u, cos_in, data)",
           "        reflected = _below_fresnel(u, -dz, data)",
           "Fresnel evaluated with the macro cosine instead of the facet cosine",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("body-emission-not-cosine", "vcavity/facet/interfaced_lambertian.py",
           "        mu = math.sqrt(1.0 - rho2)\n",
           "        mu = 1.0 - rho2\n        a = a * math.sqrt((1.0 - mu * mu) / rho2)\n"
           "        b = b * math.sqrt((1.0 - mu * mu) / rho2)\n",
           "body re-emission uniform in mu (not cosine-weighted)",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("no-transmission-on-body-exit", "vcavity/facet/interfaced_lambertian.py",
           "        if variant == FULL:\n            # accept with probability T(mu)",
           "        if variant == -1:\n            # accept with probability T(mu)",
           "light leaving the body is not filtered by the interface's transmittance",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("solid-angle-x2", "vcavity/sensor/grid.py",
           "projected = 0.5 * np.pi * _projected_integral_over_rectangles(*self.cell_bounds())",
           "projected = np.pi * _projected_integral_over_rectangles(*self.cell_bounds())",
           "every cell's projected solid angle doubled (tables' BRDF off by 2x)",
           ("tests/validation/test_table_units_reference.py",)),
    Mutant("max-instead-of-min-masking", "vcavity/microfacet/common.py",
           "    return gi if gi < go else go",
           "    return gi if gi > go else go",
           "V-cavity G2 = max(G1_i, G1_o) instead of min (the analytic model)",
           ("tests/validation/test_f1_vs_vcavity.py",)),
    Mutant("beyond-k-as-k", "vcavity/kernels/loop.py",
           "exit_row[n_exits] = k if k <= max_order else 0",
           "exit_row[n_exits] = min(k, max_order)",
           "exits with more than K bounces counted as order K instead of the beyond-K slot",
           ("tests/validation/test_orders_reference.py",)),
    Mutant("alpha-xy-swapped", "vcavity/microfacet/common.py",
           'return np.array([values["alpha_x"], values["alpha_y"]], dtype=np.float64)',
           'return np.array([values["alpha_y"], values["alpha_x"]], dtype=np.float64)',
           "Beckmann's and GGX's alpha_x and alpha_y swapped in their shared parameter packing",
           ("tests/validation/test_anisotropy_reference.py",)),
    Mutant("mirrored-exit-azimuth", "vcavity/kernels/scaffold.py",
           "    wy = dx * sin_phi + dy * cos_phi",
           "    wy = -(dx * sin_phi + dy * cos_phi)",
           "exit direction mirrored about the x axis when leaving the groove",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("chi-square-complement-dropped", "vcavity/analytic/statistics.py",
           "    if rest_exp > 0.0 or rest_obs > 0.0:\n        obs.append(rest_obs)",
           "    if False:\n        obs.append(rest_obs)",
           "the 'not in any cell' category left out of the chi-square",
           ("tests/analytic/test_statistics.py",)),
    Mutant("gaussian-inverse-cdf-factor", "vcavity/microfacet/gaussian.py",
           "    w = math.sqrt(-2.0 * math.log1p(-u1))",
           "    w = math.sqrt(-math.log1p(-u1))",
           "factor 2 dropped in the Gaussian's tabulated inverse CDF",
           ("tests/microfacet/test_distributions.py",)),
    Mutant("oren-nayar-term-removed", "vcavity/analytic/oren_nayar.py",
           "    if interreflection:\n        value = single + 0.17",
           "    if False:\n        value = single + 0.17",
           "the 0.17 inter-reflection term of Oren-Nayar removed",
           ("tests/analytic/test_oren_nayar_walter.py",)),
    Mutant("chunk-local-block-index", "vcavity/kernels/scaffold.py",
           "    block = first_block + b\n",
           "    block = b\n",
           "RNG block index local to the chunk (chunks repeat streams)",
           ("tests/simulate/test_pipeline.py",)),
    Mutant("emergence-probability-is-kd", "vcavity/facet/interfaced_lambertian.py",
           '    head = [eta, float(emergence_probability(float(values["kd"]), eta))]',
           '    head = [eta, float(values["kd"])]',
           "body re-emission probability kd instead of kd (1 - r_i)/(1 - kd r_i)",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("fresnel-inverted-index", "vcavity/facet/interfaced_lambertian.py",
           "    eta = float(values[\"eta\"])\n    head = ",
           "    eta = 1.0 / float(values[\"eta\"])\n    head = ",
           "the facet's Fresnel term evaluated with 1/eta (light from inside)",
           ("tests/validation/test_f1_reference.py",)),
    Mutant("conductor-k-sign", "vcavity/facet/fresnel_conductor.py",
           "    im_n2 = 2.0 * e * kk  # Im n^2 / s^2",
           "    im_n2 = -2.0 * e * kk  # Im n^2 / s^2",
           "the conductor's k sign flipped inside the Fresnel formula (index eta - i k: a gain medium)",
           ("tests/facet/test_fresnel_conductor.py",)),
    Mutant("conductor-rs-only", "vcavity/facet/fresnel_conductor.py",
           "    return min(0.5 * (r_s * r_s + r_p * r_p), 1.0)",
           "    return min(r_s * r_s, 1.0)",
           "the conductor's F is R_s alone instead of (R_s + R_p)/2",
           ("tests/facet/test_fresnel_conductor.py",)),
    Mutant("bracket-bounds-swapped", "vcavity/facet/common.py",
           "    brackets[:, 0] = np.minimum(ends[:-1], ends[1:])",
           "    brackets[:, 0] = np.maximum(ends[:-1], ends[1:])",
           "the lower bound of each reflectance bracket is the bin's larger end value",
           ("tests/facet/test_conductor.py",)),
    Mutant("conductor-event-inverted", "vcavity/facet/conductor.py",
           "    if _below_reflectance(u, cos_in, data):",
           "    if not _below_reflectance(u, cos_in, data):",
           "the conductor reflects with probability 1 - F and absorbs with probability F",
           ("tests/facet/test_conductor.py",)),
    Mutant("conductor-macro-cosine", "vcavity/facet/conductor.py",
           "    if _below_reflectance(u, cos_in, data):",
           "    if _below_reflectance(u, -dz, data):",
           "the conductor's F evaluated with the macro cosine instead of the facet cosine",
           ("tests/validation/test_conductor_walk.py",)),
    Mutant("paired-values-shifted", "vcavity/sweep/axes.py",
           "        return {key: values[j] for key, values in self.settings}",
           "        return {key: values[(j + 1) % len(values)] for key, values in self.settings}",
           "a paired axis's point j takes the values of point j + 1 (lists misaligned with the labels)",
           ("tests/sweep/test_paired.py",)),
    Mutant("beckmann-radial-slope", "vcavity/microfacet/beckmann.py",
           "    r_over_sqrt_s = math.sqrt(-math.log(s) / s)",
           "    r_over_sqrt_s = math.sqrt(-math.log(s)) / s",
           "Beckmann's trig-free groove sampler with a wrong radial slope",
           ("tests/microfacet/test_distributions.py",)),
    Mutant("fold-drops-model-of-mirror-cell", "vcavity/estimators/counts.py",
           "            model = model + np.where(pair, model[mirror], 0.0)",
           "            model = model + 0.0",
           "exact-f1 with the fold: a pair cell's f1 is its own model over twice the area (half the model), "
           "the mirror cell's model dropped",
           ("tests/estimators/test_counts.py",)),
    Mutant("fold-drops-model-error", "vcavity/estimators/counts.py",
           "            model_error = model_error + np.where(pair, model_error[mirror], 0.0)  # bound, not RMS",
           "            model_error = np.where(pair, 0.0, model_error)",
           "exact-f1 with the fold: the model's error left out of a folded pair's brdf_stderr",
           ("tests/estimators/test_counts.py",)),
    Mutant("dask-unit-offset", "vcavity/simulate/dask.py",
           "    return simulation.execute(unit)",
           "    return simulation.execute(type(unit)(unit.direction, unit.first_block + 1, unit.n_blocks))",
           "a Dask worker traces its work unit one RNG block late",
           ("tests/simulate/test_dask_quick.py",)),
    Mutant("albedo-lut-node-grid", "vcavity/export/albedo_lut.py",
           "    expected = (np.arange(n) + 0.5) / n",
           "    expected = np.arange(n) / max(n - 1, 1)",
           "the albedo LUT accepts a node-centred mu grid (ends included) instead of the midpoints",
           ("tests/export/test_albedo_lut.py",)),
    Mutant("read-albedo-unchecked", "vcavity/io/checks.py",
           '    total = np.einsum("...c,c->...", brdf, area)',
           '    return\n    total = np.einsum("...c,c->...", brdf, area)',
           "open_table and open_sweep accept an albedo that is not the sum of brdf x projected solid angle",
           ("tests/io/test_table_checks.py",)),
    Mutant("read-done-flag-unchecked", "vcavity/io/checks.py",
           '    check_flags("done", done, location)',
           "    pass",
           "open_sweep accepts done flags other than 0 and 1 (a resume then runs nothing)",
           ("tests/io/test_table_checks.py",)),
    Mutant("sweep-commit-flag-before-values", "vcavity/io/sweep_points.py",
           'SEAL = ("checksum", "done")',
           "SEAL = ()",
           "a sweep point's done flag is written among its values, before the last of them and its checksum",
           ("tests/sweep/test_commit.py",)),
    Mutant("sweep-checksum-unverified", "vcavity/io/sweep_table.py",
           '    good = sweep_checksum.verified(sweep.data, dims, sweep.point_axes, done, sweep.data["checksum"])',
           "    good = done == 1",
           "open_sweep trusts done = 1 without the point's checksum (a damaged point is never rerun)",
           ("tests/sweep/test_commit.py",)),
    Mutant("sweep-torn-values-kept", "vcavity/io/sweep_table.py",
           "        if done[index] == 0:\n            sweep.reset(index)",
           "        if False:\n            sweep.reset(index)",
           "open_sweep keeps the bytes a cut-short commit left in a pending point instead of NaN / 0",
           ("tests/sweep/test_commit.py",)),
)


def _tracked_files() -> list[str]:
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True)
    return [line for line in out.stdout.splitlines() if line]


def _copy_tree(destination: Path) -> None:
    for name in _tracked_files():
        source = ROOT / name
        if not source.is_file():
            continue  # deleted in the work tree
        target = destination / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source, target)


def _apply(mutant: Mutant, tree: Path) -> bool:
    path = tree / mutant.path
    text = path.read_text()
    if text.count(mutant.old) != 1:
        return False
    path.write_text(text.replace(mutant.old, mutant.new))
    return True


def run_mutant(mutant: Mutant, quick: bool, keep: bool) -> tuple[str, float, str]:
    """(verdict, seconds, first failing test or message) for one mutant."""
    tree = Path(tempfile.mkdtemp(prefix=f"vcavity-mutant-{mutant.name}-"))
    try:
        _copy_tree(tree)
        if not _apply(mutant, tree):
            return "STALE", 0.0, f"text not found exactly once in {mutant.path}"
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
        env["NUMBA_CACHE_DIR"] = str(tree / ".numba-cache")
        env["PYTHONPATH"] = str(tree)
        targets = list(mutant.caught_by) + ([] if quick else ["tests"])
        command = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-rf", *targets]
        start = time.perf_counter()
        done = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        failed = [line[len("FAILED "):].split(" - ")[0] for line in done.stdout.splitlines()
                  if line.startswith("FAILED ")]
        # -x under pytest-xdist (the default -n 2) stops the other worker: exit 2 with failures
        if done.returncode == 1 or (done.returncode == 2 and failed):
            return "CAUGHT", seconds, failed[0] if failed else "(failures)"
        if done.returncode == 0:
            return "SURVIVED", seconds, ""
        tail = (done.stdout + done.stderr).strip().splitlines()[-1:] or ["?"]
        return "ERROR", seconds, f"pytest exit {done.returncode}: {tail[0][:150]}"
    finally:
        if keep:
            print(f"  kept {tree}", flush=True)
        else:
            shutil.rmtree(tree, ignore_errors=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", metavar="NAME", help="run only this mutant (repeatable)")
    parser.add_argument("--list", action="store_true", help="list the mutants and exit")
    parser.add_argument("--quick", action="store_true",
                        help="run only each mutant's catching tests, not the whole default suite")
    parser.add_argument("--keep", action="store_true", help="keep the mutant copies (for debugging)")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTANTS if not args.only or m.name in args.only]
    unknown = set(args.only or ()) - {m.name for m in MUTANTS}
    if unknown:
        parser.error(f"unknown mutant(s): {', '.join(sorted(unknown))}")
    if args.list:
        for m in chosen:
            print(f"{m.name:32s} {m.what}\n{'':32s} caught by: {', '.join(m.caught_by)}")
        return 0
    results = []
    for m in chosen:
        verdict, seconds, detail = run_mutant(m, args.quick, args.keep)
        results.append(verdict)
        print(f"{m.name:32s} {verdict:8s} {seconds:7.1f} s  {detail}", flush=True)
    caught = results.count("CAUGHT")
    print(f"{caught} of {len(results)} mutants caught"
          + ("" if caught == len(results) else f"; not caught: {len(results) - caught}"))
    return 0 if caught == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
