"""``vcavity export SWEEP.h5 FILE --format albedo-lut``: the tables are the sweep's albedos in
the documented layout (alpha rows, mu columns, both ascending), E_avg is the midpoint rule
(checked against closed forms), the C header compiles and holds the .npz's values, what
cannot be a LUT is refused in one line with nothing written, and a small real sweep of
lossless Lambertian facets exports end to end with f1 albedos that match an independent
reference.

Synthetic sweeps (tests/export/synthetic_sweeps.py) carry albedos given by closed-form
functions of (mu, alpha); expected values are read back with xarray (h5netcdf), a reader
independent of vcavity's. Everything but the last test is exact or rounding-level. The
last test's z-tests (15, Sidak-corrected) have a family-wise false-positive rate of 1 %.
"""

import hashlib
import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import vcavity
from tests.reference import lambertian_orders as ref_lambert
from tests.reference import materials as ref_materials
from tests.export.synthetic_sweeps import synthetic_sweep
from vcavity.cli import main


def _midpoint_theta(n):
    """theta_i_deg (ascending, so mu descending in the file) of mu = (i + 0.5)/n."""
    return [math.degrees(math.acos((i + 0.5) / n)) for i in reversed(range(n))]


def _mu(coords):
    return math.cos(math.radians(coords.get("theta_i_deg", 60.0)))


C_F1 = 0.3


def _albedo(coords, order):
    """Closed forms with known averages 2 int_0^1 E mu dmu:
    f_inf: 1 - alpha (1 - mu)^2 -> 1 - alpha / 6;  f1: (0.8 - C alpha) mu^2 + 0.1 -> (0.8 - C alpha)/2 + 0.1;
    f2: 0.05 + 0.1 alpha (no mu: the midpoint rule is exact)."""
    mu, alpha = _mu(coords), coords.get("alpha", 0.5)
    return {0: 1.0 - alpha * (1.0 - mu) ** 2, 1: (0.8 - C_F1 * alpha) * mu ** 2 + 0.1,
            2: 0.05 + 0.1 * alpha}[order]


def _paths(coords):
    """Different per direction: a stderr computed with another direction's paths shows."""
    return 10_000 + int(round(1000 * _mu(coords))) + int(round(100 * coords.get("alpha", 0)))


ALPHA = [0.5, 0.1, 0.3]  # not ascending: the LUT sorts the rows
THETA4 = _midpoint_theta(4)


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lut")
    grid = [("alpha", ALPHA), ("eta", [1.5]), ("theta_i_deg", THETA4)]
    made = {
        "lut": synthetic_sweep(folder / "lut.h5", grid, _albedo, paths=_paths),
        "theta_first": synthetic_sweep(folder / "theta_first.h5", [("theta_i_deg", THETA4), ("alpha", ALPHA)],
                                       _albedo, paths=_paths),
        "fine": synthetic_sweep(folder / "fine.h5", [("alpha", [0.2, 0.5, 1.0]), ("theta_i_deg", _midpoint_theta(32))],
                                _albedo, paths=_paths),
        "exact": synthetic_sweep(folder / "exact.h5", grid, _albedo, paths=_paths, estimator="exact-f1"),
        "paper": synthetic_sweep(folder / "paper.h5", grid, _albedo, paths=_paths, estimator="paper"),
        # refused
        "no_theta": synthetic_sweep(folder / "no_theta.h5", [("alpha", ALPHA)], _albedo, paths=_paths),
        "no_alpha": synthetic_sweep(folder / "no_alpha.h5", [("eta", [1.5]), ("theta_i_deg", THETA4)], _albedo),
        "anisotropic_material": synthetic_sweep(
            folder / "aniso.h5", [("theta_i_deg", THETA4)], _albedo,
            material={"distribution": "ggx", "facet": "interfaced_lambertian", "kd": 1.0, "eta": 1.0,
                      "alpha_x": 0.1, "alpha_y": 0.3}),
        "alpha_x": synthetic_sweep(folder / "alpha_x.h5", [("alpha_x", [0.1, 0.2]), ("theta_i_deg", THETA4)],
                                   _albedo),
        "eta_axis": synthetic_sweep(folder / "eta_axis.h5", [("alpha", ALPHA), ("eta", [1.0, 1.5, 2.0]),
                                                             ("theta_i_deg", THETA4)], _albedo),
        "pending": synthetic_sweep(folder / "pending.h5", grid, _albedo, pending=[{"alpha": 0.3}]),
        "no_f_inf": synthetic_sweep(folder / "no_f_inf.h5", grid, _albedo, orders=(1, 2)),
        "no_f1": synthetic_sweep(folder / "no_f1.h5", grid, _albedo, orders=(0,)),
        "coarse_mu": synthetic_sweep(folder / "coarse_mu.h5", [("alpha", ALPHA), ("theta_i_deg", [0, 45, 70])],
                                     _albedo),
    }
    return made


def _export(source, out, *options):
    return main(["export", str(source), str(out), "--format", "albedo-lut", *options])


def _read_sweep(path, order):
    """(alpha ascending, theta_i_deg of mu ascending, albedo[alpha, mu], paths[alpha, mu]) by xarray."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        ds = ds.squeeze(drop=True)  # the single-valued axes (eta)
        ds = ds.sortby("alpha").sortby("theta_i_deg", ascending=False)  # mu = cos(theta) ascending
        albedo = ds.albedo.sel(order=order).transpose("alpha", "theta_i_deg").values
        paths = ds.paths.transpose("alpha", "theta_i_deg").values
        return ds.alpha.values, ds.theta_i_deg.values, albedo, paths


@pytest.mark.parametrize("name", ["lut", "theta_first"])
def test_npz_holds_the_sweep_albedo_with_alpha_rows_and_mu_columns(sweeps, tmp_path, name, capsys):
    out = tmp_path / "lut.npz"
    assert _export(sweeps[name], out) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out} (albedo-lut, f_inf)"
    lut = np.load(out)
    alpha, theta, e_inf, paths = _read_sweep(sweeps[name], 0)
    _, _, e_1, _ = _read_sweep(sweeps[name], 1)
    np.testing.assert_array_equal(lut["alpha"], sorted(ALPHA))
    np.testing.assert_array_equal(lut["alpha"], alpha)
    np.testing.assert_allclose(lut["mu"], (np.arange(4) + 0.5) / 4, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(lut["theta_i_deg"], theta)
    assert lut["E"].shape == (3, 4)  # (alpha, mu): a transposed table is (4, 3)
    np.testing.assert_array_equal(lut["E"], e_inf)
    np.testing.assert_array_equal(lut["E_f1"], e_1)
    np.testing.assert_array_equal(lut["paths"], paths)
    # the closed form at the LUT's own coordinates: rows alpha, columns mu
    a, m = np.meshgrid(lut["alpha"], lut["mu"], indexing="ij")
    np.testing.assert_allclose(lut["E"], 1.0 - a * (1.0 - m) ** 2, rtol=1e-12)
    np.testing.assert_allclose(lut["E_f1_stderr"], np.sqrt(e_1 * (1 - e_1) / paths), rtol=1e-12)
    np.testing.assert_allclose(lut["E_stderr"], np.sqrt(e_inf * (1 - e_inf) / paths), rtol=1e-12)


def test_E_avg_is_the_midpoint_rule_within_its_error_bound(sweeps, tmp_path):
    """32 midpoints: |E_avg - closed form| <= h^2/24 max|g''| with g = 2 mu E (h = 1/32):
    f_inf: g'' = -2 alpha (6 mu - 4), bound alpha h^2 / 3; f1: g'' = 12 c mu, bound c h^2 / 2."""
    out = tmp_path / "fine.npz"
    assert _export(sweeps["fine"], out) == 0
    lut = np.load(out)
    h = 1.0 / 32
    alpha = lut["alpha"]
    np.testing.assert_array_equal(alpha, [0.2, 0.5, 1.0])
    assert np.all(np.abs(lut["E_avg"] - (1.0 - alpha / 6.0)) <= alpha * h * h / 3.0)
    c = 0.8 - C_F1 * alpha
    assert np.all(np.abs(lut["E_avg_f1"] - (c / 2.0 + 0.1)) <= c * h * h / 2.0)
    mu = lut["mu"]
    np.testing.assert_allclose(lut["E_avg_stderr"], 2.0 / 32 * np.sqrt(np.sum((lut["E_stderr"] * mu) ** 2, axis=1)),
                               rtol=1e-12)


def test_order_option_picks_E_and_f1_stays(sweeps, tmp_path, capsys):
    out = tmp_path / "f2.npz"
    assert _export(sweeps["fine"], out, "--order", "2") == 0
    assert capsys.readouterr().out.strip() == f"wrote {out} (albedo-lut, f2)"
    lut = np.load(out)
    _, _, e_2, _ = _read_sweep(sweeps["fine"], 2)
    _, _, e_1, _ = _read_sweep(sweeps["fine"], 1)
    np.testing.assert_array_equal(lut["E"], e_2)
    np.testing.assert_array_equal(lut["E_f1"], e_1)
    # E_2 does not depend on mu: g = 2 mu E is linear, the midpoint rule is exact
    np.testing.assert_allclose(lut["E_avg"], 0.05 + 0.1 * lut["alpha"], rtol=1e-13)
    assert str(lut["order"]) == "f2"


def test_metadata_strings(sweeps, tmp_path):
    out = tmp_path / "m.npz"
    assert _export(sweeps["lut"], out) == 0
    lut = np.load(out)  # no pickles: plain unicode arrays
    assert str(lut["vcavity_version"]) == vcavity.__version__ and str(lut["sweep_seed"]) == "5"
    assert json.loads(str(lut["material"])) == {"distribution": "beckmann", "facet": "interfaced_lambertian",
                                                "kd": 0.9, "eta": 1.5, "phi_i_deg": 0.0}
    assert str(lut["order"]) == "f_inf" and str(lut["estimator"]) == "analog"
    assert "midpoint" in str(lut["quadrature"]) and "binomial" in str(lut["stderr"])


def test_stderr_follows_the_estimator(sweeps, tmp_path):
    """exact-f1: f1 is analytic (no stderr), f_inf's is binomial of the simulated part
    E_inf - E_f1; paper: the sweep keeps no albedo error, so there is none."""
    out = tmp_path / "e.npz"
    assert _export(sweeps["exact"], out) == 0
    lut = np.load(out)
    assert "E_f1_stderr" not in lut.files and "E_avg_f1_stderr" not in lut.files
    _, _, e_inf, paths = _read_sweep(sweeps["exact"], 0)
    _, _, e_1, _ = _read_sweep(sweeps["exact"], 1)
    p = e_inf - e_1
    np.testing.assert_allclose(lut["E_stderr"], np.sqrt(p * (1 - p) / paths), rtol=1e-12)
    out = tmp_path / "p.npz"
    assert _export(sweeps["paper"], out) == 0
    lut = np.load(out)
    assert not [name for name in lut.files if name.endswith("_stderr")]
    assert "not available" in str(lut["stderr"])


C_PROGRAM = r"""
#include <stdio.h>
#include "lut.h"
#include "lut.h"  /* the include guard makes a second include harmless */
#define DUMP2(name) for (int a = 0; a < VCAVITY_LUT_N_ALPHA; ++a) for (int m = 0; m < VCAVITY_LUT_N_MU; ++m) \
    printf(#name " %d %d %.9g\n", a, m, (double)name[a][m]);
#define DUMP1(name, n) for (int a = 0; a < n; ++a) printf(#name " %d 0 %.9g\n", a, (double)name[a]);
int main(void) {
    printf("N_MU %d\nN_ALPHA %d\n", VCAVITY_LUT_N_MU, VCAVITY_LUT_N_ALPHA);
    DUMP1(vcavity_lut_mu, VCAVITY_LUT_N_MU) DUMP1(vcavity_lut_alpha, VCAVITY_LUT_N_ALPHA)
    DUMP2(vcavity_E_f1) DUMP2(vcavity_E) DUMP2(vcavity_E_f1_stderr) DUMP2(vcavity_E_stderr)
    DUMP1(vcavity_E_avg_f1, VCAVITY_LUT_N_ALPHA) DUMP1(vcavity_E_avg, VCAVITY_LUT_N_ALPHA)
    DUMP1(vcavity_E_avg_f1_stderr, VCAVITY_LUT_N_ALPHA) DUMP1(vcavity_E_avg_stderr, VCAVITY_LUT_N_ALPHA)
    return 0;
}
"""


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs a C compiler")
def test_c_header_compiles_and_equals_the_npz(sweeps, tmp_path):
    assert _export(sweeps["lut"], tmp_path / "lut.npz") == 0
    assert _export(sweeps["lut"], tmp_path / "lut.h") == 0
    (tmp_path / "dump.c").write_text(C_PROGRAM)
    flags = ["-Wall", "-Wextra", "-pedantic", "-Werror"]
    subprocess.run(["gcc", "-std=c99", *flags, "-o", str(tmp_path / "dump"), str(tmp_path / "dump.c")], check=True,
                   cwd=tmp_path)
    if shutil.which("g++") is not None:  # the header is C++ too
        (tmp_path / "dump.cpp").write_text(C_PROGRAM)
        subprocess.run(["g++", "-std=c++11", *flags, "-c", "-o", str(tmp_path / "dump_cpp.o"),
                        str(tmp_path / "dump.cpp")], check=True, cwd=tmp_path)
    output = subprocess.run([str(tmp_path / "dump")], check=True, capture_output=True, text=True).stdout
    lines = output.splitlines()
    assert lines[:2] == ["N_MU 4", "N_ALPHA 3"]
    dumped = {}
    for line in lines[2:]:
        name, a, m, value = line.split()
        dumped.setdefault(name.removeprefix("vcavity_"), {})[(int(a), int(m))] = float(value)
    lut = np.load(tmp_path / "lut.npz")
    for name, values in dumped.items():
        key = {"lut_mu": "mu", "lut_alpha": "alpha"}.get(name, name)
        expected = np.atleast_2d(lut[key]).T if lut[key].ndim == 1 else lut[key]
        got = np.array([[values[(a, m)] for m in range(expected.shape[1])] for a in range(expected.shape[0])])
        np.testing.assert_allclose(got, expected, rtol=2.0 ** -23, err_msg=name)  # float: 24-bit mantissa
    text = (tmp_path / "lut.h").read_text()
    assert f"vcavity_version: {vcavity.__version__}" in text and "sweep_seed: 5" in text
    assert "order: f_inf" in text
    assert "static const float vcavity_E[VCAVITY_LUT_N_ALPHA][VCAVITY_LUT_N_MU]" in text


def _sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


REFUSED = [
    ("lut", "x.txt", [], "FILE = '{out}': --format albedo-lut writes .npz or .h"),
    ("no_theta", "x.npz", [], "has no theta_i_deg axis"),
    ("no_alpha", "x.npz", [], "has no alpha axis; the albedo LUT is E(mu, alpha): sweep alpha"),
    ("anisotropic_material", "x.npz", [], "material alpha_x = 0.1, alpha_y = 0.3 is anisotropic"),
    ("alpha_x", "x.h", [], "roughness axis alpha_x is anisotropic roughness"),
    ("eta_axis", "x.npz", [], "the LUT is E(mu, alpha); axis eta has 3 values: sweep one eta per file"),
    ("pending", "x.npz", [], "1 of 3 points are not done; run vcavity sweep synthetic.toml -o "),
    ("lut", "x.npz", ["--order", "5"], "--order = '5': sweep '{src}' has orders 0 (f_inf), 1, 2"),
    ("no_f_inf", "x.npz", [], "--order = '0': sweep '{src}' has orders 1, 2 (sweep with track_all_orders = true)"),
    ("no_f1", "x.h", ["--order", "inf"], "has no order 1 (orders 0 (f_inf)); the LUT always holds E_f1"),
    ("coarse_mu", "x.npz", [], "are not the midpoints (i + 0.5)/3 of 3 equal bins of [0, 1]"),
]


@pytest.mark.parametrize("name, file, options, message", REFUSED, ids=[f"{r[0]}-{r[1]}" for r in REFUSED])
def test_refusals_are_one_line_exit_2_and_leave_files_alone(sweeps, tmp_path, capsys, name, file, options, message):
    source = sweeps[name]
    fresh = tmp_path / "fresh" / file
    fresh.parent.mkdir()
    assert _export(source, fresh, *options) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    expected = message.format(out=fresh, src=source)
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("vcavity: error: "), lines
    assert expected in lines[0], lines[0]
    assert list(fresh.parent.iterdir()) == []  # no output, no temporary file
    old = tmp_path / "old" / file
    old.parent.mkdir()
    old.write_bytes(b"an earlier export\n")
    digest = _sha256(old)
    assert _export(source, old, "--overwrite", *options) == 2
    assert expected.replace(str(fresh), str(old)) in capsys.readouterr().err
    assert _sha256(old) == digest and list(old.parent.iterdir()) == [old]


@pytest.mark.parametrize("grid", ["nodes-with-ends", "right-ends", "midpoints-shifted"])
def test_a_mu_grid_other_than_the_midpoints_is_refused(tmp_path, capsys, grid):
    """The midpoint rule needs mu = (i + 0.5)/n; a node-centred grid (mu = i/(n - 1), the
    ends included), the bins' right ends (mu = (i + 1)/n) or midpoints shifted by 1e-4 are
    refused in one line, exit 2, nothing written; the midpoints themselves are accepted."""
    n = 4
    mu = {"nodes-with-ends": np.arange(n) / (n - 1), "right-ends": (np.arange(n) + 1.0) / n,
          "midpoints-shifted": (np.arange(n) + 0.5) / n + 1e-4}[grid]
    theta = sorted(float(np.degrees(np.arccos(np.clip(m, -1.0, 1.0)))) for m in mu)
    source = synthetic_sweep(tmp_path / f"{grid}.h5", [("alpha", ALPHA), ("theta_i_deg", theta)], _albedo)
    out = tmp_path / "out" / "lut.npz"
    out.parent.mkdir()
    assert _export(source, out) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and f"are not the midpoints (i + 0.5)/{n} of {n} equal bins of [0, 1]" in lines[0]
    assert list(out.parent.iterdir()) == []
    midpoints = synthetic_sweep(tmp_path / "midpoints.h5", [("alpha", ALPHA), ("theta_i_deg", _midpoint_theta(n))],
                                _albedo)
    assert _export(midpoints, out) == 0 and out.is_file()


# ---------------------------------------------------------------- a real sweep, end to end

REAL_ALPHA = [1.0, 0.2, 0.6]
#: 12 f1 z-tests + 3 E_avg_f1 z-tests, Sidak-corrected to a family-wise false alarm of 1 %
Z_LIMIT = 3.45  # each test: two-sided normal tail 5.6e-4 < 1 - 0.99 ** (1 / 15) = 6.7e-4 (|z| > 3.40)


def test_a_small_lossless_sweep_exports_end_to_end(tmp_path, capsys):
    """Beckmann V-cavities with Lambertian facets (kd = 1, eta = 1): nothing is absorbed, so
    E_inf = 1 - truncated - degenerate; E_f1 against the 2-D view-factor reference
    (tests/reference/lambertian_orders.py, quadrature error <= 6e-5 here, 0.03 sigma) and
    E_avg_f1 against the midpoint rule applied to the reference."""
    spec = tmp_path / "lossless.toml"
    theta = ", ".join(f"{t:.10f}" for t in THETA4)
    spec.write_text('[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 1.0\neta = 1.0\n'
                    "[incidence]\npaths = 40_000\n[simulation]\nseed = 23\nmax_order = 2\nsensor_resolution = 9\n"
                    f"[sweep]\nalpha = {REAL_ALPHA}\ntheta_i_deg = [{theta}]\n")
    sweep = tmp_path / "lossless.h5"
    assert main(["sweep", str(spec), "-o", str(sweep), "-q"]) == 0
    out = tmp_path / "lossless.npz"
    assert _export(sweep, out) == 0
    capsys.readouterr()
    lut = np.load(out)
    alpha, _, e_inf, paths = _read_sweep(sweep, 0)
    np.testing.assert_array_equal(lut["E"], e_inf)
    with xr.open_dataset(sweep, engine="h5netcdf") as ds:
        ds = ds.sortby("alpha").sortby("theta_i_deg", ascending=False)
        absorbed = ds.absorbed.transpose("alpha", "theta_i_deg").values
        lost = (ds.truncated + ds.degenerate).transpose("alpha", "theta_i_deg").values
    assert np.all(absorbed == 0.0)
    np.testing.assert_allclose(lut["E"], 1.0 - lost, rtol=1e-12)
    reference = np.zeros((3, 4))
    for a, value in enumerate(alpha):
        material = ref_materials.parse_material({"distribution": "beckmann", "alpha": float(value), "kd": 1.0,
                                                 "eta": 1.0})
        for m, mu in enumerate(lut["mu"]):
            reference[a, m] = ref_lambert.albedos(material, np.array([math.sqrt(1 - mu * mu), 0.0, mu]))[0]
    z = (lut["E_f1"] - reference) / lut["E_f1_stderr"]
    assert np.all(np.abs(z) < Z_LIMIT), z
    z_avg = (lut["E_avg_f1"] - 2.0 / 4 * reference @ lut["mu"]) / lut["E_avg_f1_stderr"]
    assert np.all(np.abs(z_avg) < Z_LIMIT), z_avg
    assert np.all(np.diff(lut["E_f1"], axis=0) < 0)  # rougher cavities: more light bounces again
