"""``estimator = "exact"``: a specular table from the every-order model, no path traced
(vcavity/estimators/exact.py). What is checked here is the plumbing into a table and the
refusals; the model itself is tested against independent references in
tests/analytic/test_specular_orders.py. The one statistical test (an analog table's
counts against the exact table, in plain NumPy) names its false-positive rate."""

import math

import h5py
import numpy as np
import pytest

from vcavity.cli import main
from vcavity.io.table import open_table

MIRROR = """[material]
distribution = "beckmann"
alpha = 0.5
facet = "mirror"
[incidence]
theta_i_deg = [10, 65]
phi_i_deg = 20
paths = {paths}
[simulation]
seed = 5
max_order = 3
sensor_resolution = 17
estimator = "{estimator}"
"""


def run(tmp_path, name, estimator, paths=400_000, extra=()):
    config = tmp_path / f"{name}.toml"
    config.write_text(MIRROR.format(paths=paths, estimator=estimator))
    out = tmp_path / f"{name}.h5"
    return main(["run", str(config), "-o", str(out), "-q", *extra]), out


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exact")
    status_exact, exact = run(folder, "exact", "exact")
    status_analog, analog = run(folder, "analog", "analog")
    assert status_exact == 0 and status_analog == 0
    return open_table(exact), open_table(analog)


def test_an_exact_table_says_it_is_deterministic(tables):
    exact, _ = tables
    assert exact.deterministic and exact.estimator == "exact"
    assert np.all(exact.paths == 0) and np.all(exact.counts == 0)
    assert np.all(exact.order_source == 1)  # every order analytic
    with h5py.File(exact.path) as h5:
        assert h5.attrs["deterministic"] == 1
    # a mirror absorbs nothing: the f_inf albedo is 1; orders 1..3 are part of it
    np.testing.assert_allclose(exact.albedo[:, 0] + exact.truncated, 1.0, atol=1e-9)
    assert np.all(exact.albedo[:, 1:].sum(axis=1) <= exact.albedo[:, 0] + 1e-12)
    assert np.all(exact.absorbed < 1e-9)
    # every order's albedo is the sum of brdf x projected solid angle (plain NumPy)
    np.testing.assert_allclose(exact.albedo, np.einsum("ikc,c->ik", exact.brdf, exact.cell_projected_solid_angle),
                               rtol=1e-12)
    # brdf_stderr is the model's error estimate: small against the values, and never negative
    assert np.all(exact.brdf_stderr >= 0.0)
    assert np.all(exact.relative_error <= 1e-3)


def test_an_analog_table_is_a_sample_of_the_exact_one(tables):
    """Pearson chi-square (plain NumPy) of the analog f2 counts against the exact table's f2
    (expected = paths x brdf x Ω⊥, cells below 5 pooled, plus the complement). The exact
    table's own error (<= 1e-3 relative) is far below the noise of 4e5 paths.
    False-positive rate: 2 x 1e-3 (one test per direction at p < 1e-3)."""
    from scipy.stats import chi2

    exact, analog = tables
    area = exact.cell_projected_solid_angle
    k = int(np.flatnonzero(exact.order == 2)[0])
    for j in range(exact.theta_i.size):
        paths = int(analog.paths[j])
        expected = paths * exact.brdf[j, k] * area
        observed = analog.counts[j, k].astype(float)
        alone = expected >= 5
        obs = list(observed[alone]) + [observed[~alone].sum(), paths - observed.sum()]
        exp = list(expected[alone]) + [expected[~alone].sum(), paths - expected.sum()]
        obs, exp = np.array(obs), np.array(exp)
        keep = exp > 0
        statistic = float(np.sum((obs[keep] - exp[keep]) ** 2 / exp[keep]))
        assert chi2.sf(statistic, keep.sum() - 1) > 1e-3, (j, statistic, keep.sum())


def test_the_target_error_is_the_model_tolerance(tmp_path):
    status, out = run(tmp_path, "coarse", "exact", extra=("--target-error", "0.02"))
    assert status == 0
    coarse = open_table(out)
    assert np.all(coarse.relative_error <= 0.02) and coarse.attrs["target_error"] == 0.02
    assert coarse.target_reached.tolist() == [1, 1]


def test_a_tolerance_the_mesh_cannot_meet_is_said(tmp_path, capsys, monkeypatch):
    """A target error below what the mesh reaches at its size cap (issue 38: exit 0 without a
    word, target_reached = -1) is stored as not reached and said in the run's report."""
    from vcavity.analytic import specular_orders

    # a cap of 16 quads a side: a tolerance of 1e-6 cannot be met, as 1e-6 at the default cap
    monkeypatch.setitem(specular_orders.specular_orders.__kwdefaults__, "max_quads", 16)
    status, out = run(tmp_path, "capped", "exact", extra=("--target-error", "1e-6"))
    assert status == 0
    table = open_table(out)
    assert table.target_reached.tolist() == [0, 0] and np.all(table.relative_error > 1e-6)
    said = [line for line in capsys.readouterr().out.splitlines() if "target error 1e-06" in line]
    assert len(said) == 2 and all("NOT reached: the model's mesh hit its size cap (error " in line for line in said)


def test_facets_with_a_body_are_refused_in_one_line(tmp_path, capsys):
    config = tmp_path / "il.toml"
    config.write_text(MIRROR.format(paths=1000, estimator="exact").replace('facet = "mirror"',
                                                                           'facet = "interfaced_lambertian"\nkd = 0.5'))
    out = tmp_path / "il.h5"
    assert main(["run", str(config), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("vcavity: error: simulation.estimator = 'exact'") and "\n" not in err
    assert "specular facets only" in err and not out.exists()


@pytest.mark.parametrize("flags, words", [
    (("--dask", "local:2"), "--dask = 'local:2': the exact estimator traces no path"),
    (("--target-error", "0.01", "--max-paths", "1000"), "does not apply to the exact estimator"),
])
def test_what_needs_paths_is_refused(tmp_path, capsys, flags, words):
    status, out = run(tmp_path, "x", "exact", extra=flags)
    assert status == 2 and not out.exists()
    assert words in capsys.readouterr().err


def test_a_sweep_of_exact_points_with_dask_is_refused_like_a_run(tmp_path, capsys):
    """Issue 38: `sweep --dask` with the exact estimator ran; a run refuses it (nothing to
    distribute). One line, exit 2, no file."""
    spec = tmp_path / "sweep.toml"
    spec.write_text(MIRROR.format(paths=1000, estimator="exact").replace("alpha = 0.5\n", "")
                    .replace("theta_i_deg = [10, 65]\n", "") + "[sweep]\nalpha = [0.3, 0.9]\ntheta_i_deg = [0, 60]\n")
    out = tmp_path / "sweep.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--dask", "local:2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vcavity: error: --dask = 'local:2': the exact estimator traces no path, there is nothing to "
                   "distribute"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.toml"]


def test_exports_and_the_table_api_take_an_exact_table(tables, tmp_path):
    exact, _ = tables
    for fmt in ("rgl", "merl"):
        assert main(["export", str(exact.path), str(tmp_path / f"t.{fmt}"), "--format", fmt]) == 0
    assert main(["export", str(exact.path), str(tmp_path / "t.csv"), "--format", "csv", "--theta-i", "65"]) == 0
    wi = np.array([math.sin(math.radians(10)), 0.0, math.cos(math.radians(10))])
    assert abs(exact.albedo_at(wi, 0) - 1.0) < 0.02  # the interpolated table of a mirror


def test_a_sweep_of_exact_points(tmp_path):
    spec = tmp_path / "sweep.toml"
    spec.write_text(MIRROR.format(paths=1000, estimator="exact").replace("alpha = 0.5\n", "")
                    .replace("theta_i_deg = [10, 65]\n", "") + "[sweep]\nalpha = [0.3, 0.9]\ntheta_i_deg = [0, 60]\n")
    out = tmp_path / "sweep.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q"]) == 0
    with h5py.File(out) as h5:
        assert np.all(h5["done"][()] == 1) and np.all(h5["paths"][()] == 0)
        np.testing.assert_allclose(h5["albedo"][..., 0], 1.0, atol=1e-9)


@pytest.mark.parametrize("estimator", ["exact", "paper"])
def test_the_microsurface_refusal_names_the_estimator_asked_for(estimator):
    """The exact estimator shares the paper estimator's V-cavity rule, and once named the
    paper estimator in its refusal (trial of issue 38: 'exact' was refused as 'paper')."""
    from vcavity import config as config_mod
    from vcavity.parameters import ConfigError

    raw = {"material": {"microsurface": "smith", "distribution": "ggx", "alpha": 0.5, "facet": "mirror"},
           "simulation": {"estimator": estimator}}
    with pytest.raises(ConfigError) as info:
        config_mod.validate(raw)
    assert str(info.value).startswith(f"simulation.estimator = {estimator!r}: is for the v-cavity microsurface")
