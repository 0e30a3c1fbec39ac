"""The estimators' arithmetic and the mirror fold (vcavity/estimators/, physics.md sec. 11).

References are written out here in plain NumPy: the reflection of the cell centres in 3-D
(not the index arithmetic of ``mirror_cells``) and the binomial formulas of
docs/hdf5-format.md. The statistical tests use fixed seeds; each names its false-alarm rate.
"""

import numpy as np
import pytest
from scipy import stats

from vcavity import config as config_mod
from vcavity.estimators import registry as estimators
from vcavity.estimators.counts import ANALYTIC, ANALYTIC_PLUS_SIMULATED, SIMULATED, relative_error
from vcavity.estimators.counts import binomial as estimate_direction
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sensor.mirror import has_mirror_symmetry, mirror_cells


def order_source(orders, estimator):
    return estimators.get(estimator).order_source(orders)

ALPHA = 1e-3  # false-alarm rate of each chi-square test below


def reflect_about_plane(directions, phi_deg):
    """Mirror image of directions about the vertical plane at azimuth phi (plain 3-D)."""
    angle = np.radians(phi_deg)
    normal = np.array([-np.sin(angle), np.cos(angle), 0.0])
    return directions - 2.0 * (directions @ normal)[:, None] * normal


@pytest.mark.parametrize("resolution", [5, 8, 57])
@pytest.mark.parametrize("phi_deg", [0.0, 45.0, 90.0, 135.0, 180.0, -45.0, 270.0])
def test_mirror_cells_reflect_the_cell_centres(resolution, phi_deg):
    sensor = EqualAreaSensor(resolution)
    mirror = mirror_cells(sensor, phi_deg)
    centres = np.asarray(sensor.cell_center)
    np.testing.assert_allclose(centres[mirror], reflect_about_plane(centres, phi_deg), atol=1e-12)
    np.testing.assert_array_equal(mirror[mirror], np.arange(sensor.n_cells))  # an involution
    # cells on the plane are their own mirror: an odd grid has a row of them at 0 deg
    on_plane = np.count_nonzero(mirror == np.arange(sensor.n_cells))
    assert on_plane == (resolution if resolution % 2 or phi_deg % 90 else 0)


def test_mirror_cells_refuse_planes_that_are_not_grid_lines():
    with pytest.raises(ValueError, match="multiples of 45"):
        mirror_cells(EqualAreaSensor(5), 30.0)


def test_which_directions_fold():
    assert has_mirror_symmetry(0.0, True) and has_mirror_symmetry(45.0, True)
    assert has_mirror_symmetry(-135.0, True) and not has_mirror_symmetry(30.0, True)
    assert has_mirror_symmetry(90.0, False) and not has_mirror_symmetry(45.0, False)
    assert not has_mirror_symmetry(float("nan"), True)


def _projected(sensor):
    return np.asarray(sensor.cell_projected_solid_angle)


def test_analog_estimate_is_the_binomial_formula():
    sensor = EqualAreaSensor(7)
    rng = np.random.default_rng(3)
    counts = rng.integers(0, 50, size=(3, sensor.n_cells))
    counts[0] = counts[1] + counts[2] + rng.integers(0, 5, size=sensor.n_cells)
    n = 100_000
    est = estimate_direction(counts, n, (0, 1, 2), _projected(sensor))
    area = _projected(sensor)
    np.testing.assert_allclose(est.brdf, counts / (n * area), rtol=1e-15)
    np.testing.assert_allclose(est.brdf_stderr, np.sqrt(counts * (1 - counts / n)) / (n * area), rtol=1e-14)
    np.testing.assert_allclose(est.albedo, counts.sum(axis=1) / n, rtol=1e-15)
    # energy-weighted relative error: sum of sigma * area over sum of f * area
    expected = np.sum(np.sqrt(counts[0] * (1 - counts[0] / n))) / np.sum(counts[0])
    assert relative_error(est, (0, 1, 2), area) == pytest.approx(expected, rel=1e-13)


def test_fold_merges_mirror_pairs():
    sensor = EqualAreaSensor(9)
    rng = np.random.default_rng(4)
    counts = rng.integers(0, 1000, size=(1, sensor.n_cells))
    n = 10**6
    mirror = mirror_cells(sensor, 0.0)
    est = estimate_direction(counts, n, (1,), _projected(sensor), mirror=mirror)
    area = _projected(sensor)
    for c in range(sensor.n_cells):
        m = mirror[c]
        if m == c:
            assert est.brdf[0, c] == pytest.approx(counts[0, c] / (n * area[c]), rel=1e-14)
            continue
        merged = counts[0, c] + counts[0, m]
        assert area[m] == pytest.approx(area[c], rel=1e-12)
        assert est.brdf[0, c] == pytest.approx(merged / (2 * n * area[c]), rel=1e-14)
        assert est.brdf_stderr[0, c] == pytest.approx(np.sqrt(merged * (1 - merged / n)) / (2 * n * area[c]),
                                                      rel=1e-13)
    assert est.albedo[0] == pytest.approx(counts.sum() / n, rel=1e-15)  # folding keeps the energy


def test_exact_f1_adds_the_model_and_its_error():
    sensor = EqualAreaSensor(6)
    area = _projected(sensor)
    rng = np.random.default_rng(5)
    n = 50_000
    counts = np.zeros((3, sensor.n_cells), np.int64)
    counts[2] = rng.integers(0, 30, size=sensor.n_cells)
    counts[0] = counts[2] + rng.integers(0, 3, size=sensor.n_cells)  # orders >= 2
    integrals = rng.uniform(1e-4, 1e-2, size=sensor.n_cells)
    error = rng.uniform(0, 1e-6, size=sensor.n_cells)
    est = estimate_direction(counts, n, (0, 1, 2), area, f1_integrals=integrals, f1_error=error)
    np.testing.assert_allclose(est.brdf[1], integrals / area, rtol=1e-15)
    np.testing.assert_allclose(est.brdf_stderr[1], error / area, rtol=1e-15)
    np.testing.assert_allclose(est.brdf[0], (integrals + counts[0] / n) / area, rtol=1e-14)
    np.testing.assert_allclose(est.brdf_stderr[0],
                               np.sqrt(counts[0] * (1 - counts[0] / n) / n**2 + error**2) / area, rtol=1e-13)
    np.testing.assert_allclose(est.brdf[2], counts[2] / (n * area), rtol=1e-15)
    assert est.albedo[1] == pytest.approx(integrals.sum(), rel=1e-14)
    assert est.albedo[0] == pytest.approx(integrals.sum() + counts[0].sum() / n, rel=1e-14)
    np.testing.assert_array_equal(order_source((0, 1, 2), "exact-f1"),
                                  [ANALYTIC_PLUS_SIMULATED, ANALYTIC, SIMULATED])
    np.testing.assert_array_equal(order_source((1, 2), "analog"), [SIMULATED, SIMULATED])


def _mirror_by_geometry(sensor, phi_deg):
    """Each cell's mirror cell found in 3-D: the cell whose centre is nearest the reflected
    centre (independent of the index arithmetic of ``mirror_cells``)."""
    centres = np.asarray(sensor.cell_center)
    reflected = reflect_about_plane(centres, phi_deg)
    return np.argmin(np.linalg.norm(reflected[:, None, :] - centres[None, :, :], axis=2), axis=1)


@pytest.mark.parametrize("phi_deg", [0.0, 45.0])
def test_folded_exact_f1_holds_the_model_merged_over_mirror_pairs(phi_deg):
    """Exact-f1 with the fold (the default for isotropic materials at phi_i = 0): the f1 row
    of a pair cell is the mean of the model over the pair, (I_c + I_m) / (2 Omega_c), not
    half of it or the cell's own; the model's error bound of the pair, e_c + e_m, is in the
    standard error of f1 and of f_inf (added to the binomial one in quadrature)."""
    sensor = EqualAreaSensor(9)
    area = _projected(sensor)
    rng = np.random.default_rng(8)
    n = 40_000
    counts = np.zeros((3, sensor.n_cells), np.int64)
    counts[2] = rng.integers(0, 40, size=sensor.n_cells)
    counts[0] = counts[2] + rng.integers(0, 4, size=sensor.n_cells)  # orders >= 2
    integrals = rng.uniform(1e-4, 1e-2, size=sensor.n_cells)  # not symmetric: the merge shows
    error = rng.uniform(1e-6, 1e-4, size=sensor.n_cells)
    mirror = _mirror_by_geometry(sensor, phi_deg)
    est = estimate_direction(counts, n, (0, 1, 2), area, mirror=mirror_cells(sensor, phi_deg),
                             f1_integrals=integrals, f1_error=error)
    pair = mirror != np.arange(sensor.n_cells)
    assert pair.sum() > sensor.n_cells // 2
    region = np.where(pair, 2.0, 1.0) * area
    model = np.where(pair, integrals + integrals[mirror], integrals)
    model_error = np.where(pair, error + error[mirror], error)
    merged = np.where(pair, counts[0] + counts[0][mirror], counts[0])
    np.testing.assert_allclose(est.brdf[1], model / region, rtol=1e-14)
    np.testing.assert_allclose(est.brdf_stderr[1], model_error / region, rtol=1e-14)
    np.testing.assert_allclose(est.brdf[0], (model + merged / n) / region, rtol=1e-14)
    np.testing.assert_allclose(est.brdf_stderr[0],
                               np.sqrt(merged * (1 - merged / n) / n**2 + model_error**2) / region, rtol=1e-13)
    assert est.albedo[1] == pytest.approx(integrals.sum(), rel=1e-14)
    assert np.sum(est.brdf[1] * area) == pytest.approx(integrals.sum(), rel=1e-13)


@pytest.mark.parametrize("estimator", ["analog", "exact-f1", "paper"])
@pytest.mark.parametrize("phi_deg", [None, 0.0, 45.0, 90.0])
def test_albedo_is_the_sum_of_brdf_times_projected_solid_angle(estimator, phi_deg):
    """For every order of every estimator, folded or not: albedo = sum_c brdf_c Omega_c,
    what the table's albedo dataset promises (docs/hdf5-format.md) and open_table checks.
    (The exact estimator's tables: tests/estimators/test_exact.py.)"""
    from vcavity.estimators.paper import weighted as estimate_weighted

    sensor = EqualAreaSensor(8)
    area = _projected(sensor)
    rng = np.random.default_rng(9)
    n = 30_000
    counts = rng.integers(0, 60, size=(4, sensor.n_cells))
    counts[0] = counts[1:].sum(axis=0) + rng.integers(0, 5, size=sensor.n_cells)
    mirror = None if phi_deg is None else mirror_cells(sensor, phi_deg)
    if estimator == "paper":
        weights = counts * rng.integers(1, 500, size=counts.shape)
        est = estimate_weighted(weights, weights * 300, n, 250.0, area, mirror=mirror)
    else:
        model = rng.uniform(0, 1e-2, size=sensor.n_cells) if estimator == "exact-f1" else None
        est = estimate_direction(counts, n, (0, 1, 2, 3), area, mirror=mirror, f1_integrals=model,
                                 f1_error=None if model is None else 0.01 * model)
    np.testing.assert_allclose(est.albedo, np.sum(est.brdf * area, axis=1), rtol=1e-13)


# --- the fold on simulated tables --------------------------------------------------------

def _run(material, phi_deg, paths, seed, fold, theta_deg=60.0, resolution=19):
    from vcavity.simulate.pipeline import simulate

    raw = {"material": material,
           "incidence": {"theta_i_deg": [theta_deg], "phi_i_deg": phi_deg, "paths": paths},
           "simulation": {"seed": seed, "max_order": 2, "sensor_resolution": resolution,
                          "fold_symmetry": fold}}
    return simulate(config_mod.validate(raw))


FIG7B = {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5}
ANISO = {"distribution": "beckmann", "alpha_x": 0.9, "alpha_y": 0.3, "kd": 0.9, "eta": 1.5}


@pytest.mark.parametrize("material, phi_deg", [(FIG7B, 0.0), (FIG7B, 45.0), (ANISO, 90.0), (ANISO, 0.0),
                                                (dict(FIG7B, microsurface="smith"), 45.0),
                                                (dict(ANISO, microsurface="smith"), 90.0)])
def test_simulated_counts_are_mirror_symmetric(material, phi_deg):
    """Under the symmetry each pair splits its paths Binomial(n_a + n_b, 1/2): the sum of
    (n_a - n_b)^2 / (n_a + n_b) over pairs is chi-square with one degree per pair. A wrong
    mirror map or a broken symmetry (e.g. anisotropy at 45 deg) fails it. The Smith walk has
    the same symmetry, so the fold serves its tables too."""
    result = _run(material, phi_deg, 400_000, seed=11, fold=False)
    mirror = mirror_cells(EqualAreaSensor(19), phi_deg)
    counts = result["counts"][0, 0]
    a = np.arange(counts.size)
    first = (mirror > a) & (counts + counts[mirror] >= 20)
    n_a, n_b = counts[first].astype(float), counts[mirror[first]].astype(float)
    statistic = np.sum((n_a - n_b) ** 2 / (n_a + n_b))
    assert first.sum() > 50
    assert stats.chi2.sf(statistic, first.sum()) > ALPHA


def test_anisotropic_counts_are_not_symmetric_at_45_degrees():
    """The test above can fail: an anisotropic material at phi_i = 45 deg has no mirror
    symmetry about its plane of incidence, and the same statistic rejects it."""
    result = _run(ANISO, 45.0, 400_000, seed=11, fold=False)
    mirror = mirror_cells(EqualAreaSensor(19), 45.0)
    counts = result["counts"][0, 0]
    first = (mirror > np.arange(counts.size)) & (counts + counts[mirror] >= 20)
    n_a, n_b = counts[first].astype(float), counts[mirror[first]].astype(float)
    assert stats.chi2.sf(np.sum((n_a - n_b) ** 2 / (n_a + n_b)), first.sum()) < 1e-6


def test_folded_table_agrees_with_unfolded_and_has_smaller_errors():
    """Folded (seed 1) against unfolded (seed 2): independent estimates of one BRDF, so
    (a - b) / sqrt(sa^2 + sb^2) is standard normal per cell; the folded error is 1/sqrt(2)
    of the unfolded one away from the plane (same counts, seed 1 both)."""
    folded = _run(FIG7B, 0.0, 1_000_000, seed=1, fold=None)
    unfolded_same = _run(FIG7B, 0.0, 1_000_000, seed=1, fold=False)
    unfolded = _run(FIG7B, 0.0, 1_000_000, seed=2, fold=False)
    assert folded["folded"][0] and not unfolded["folded"][0]
    np.testing.assert_array_equal(folded["counts"], unfolded_same["counts"])  # raw counts unfolded
    sensor = EqualAreaSensor(19)
    mirror = mirror_cells(sensor, 0.0)
    busy = (unfolded_same["counts"][0, 0] >= 400) & (mirror != np.arange(mirror.size))
    ratio = folded["brdf_stderr"][0, 0, busy] / unfolded_same["brdf_stderr"][0, 0, busy]
    assert np.median(ratio) == pytest.approx(1 / np.sqrt(2), rel=0.03)
    lit = unfolded["counts"][0, 0] >= 30
    sigma = np.hypot(folded["brdf_stderr"][0, 0, lit], unfolded["brdf_stderr"][0, 0, lit])
    z = (folded["brdf"][0, 0, lit] - unfolded["brdf"][0, 0, lit]) / sigma
    # pairs share a folded value: count each pair once in the chi-square
    keep = (mirror[lit] >= np.flatnonzero(lit))
    assert stats.chi2.sf(np.sum(z[keep] ** 2), keep.sum()) > ALPHA
    assert relative_error(folded_estimate(folded), folded["order"], sensor.cell_projected_solid_angle) \
        < 0.75 * unfolded_same["relative_error"][0]


def folded_estimate(table):
    from vcavity.estimators.counts import DirectionEstimate

    return DirectionEstimate(table["brdf"][0], table["brdf_stderr"][0], table["albedo"][0])


# --- configuration ------------------------------------------------------------------------

@pytest.mark.parametrize("simulation, incidence, field, words", [
    ({"estimator": "exactly"}, {}, "simulation.estimator", "accepted: 'analog', 'exact-f1', 'paper', 'exact'"),
    ({"estimator": "exact"}, {}, "simulation.estimator", "is for specular facets only"),
    ({"estimator": "exact-f1", "max_order": 1, "track_all_orders": False}, {}, "simulation.estimator",
     "nothing is simulated"),
    ({"fold_symmetry": "yes"}, {}, "simulation.fold_symmetry", "true or false"),
    ({"fold_symmetry": True}, {"phi_i_deg": 30}, "simulation.fold_symmetry", "multiple of 45"),
    ({"target_error": 0}, {}, "simulation.target_error", "(0, 1)"),
    ({"target_error": 1.5}, {}, "simulation.target_error", "(0, 1)"),
    ({"target_error": 0.01, "track_all_orders": False}, {}, "simulation.target_error", "track_all_orders"),
    ({"max_paths": 1000}, {}, "simulation.max_paths", "only with simulation.target_error"),
    ({"target_error": 0.01, "max_paths": 0}, {}, "simulation.max_paths", ">= 1"),
])
def test_bad_estimation_settings_are_one_line_errors(simulation, incidence, field, words):
    raw = {"material": FIG7B, "incidence": {"theta_i_deg": [30], **incidence}, "simulation": simulation}
    with pytest.raises(config_mod.ConfigError) as info:
        config_mod.validate(raw)
    message = str(info.value)
    assert message.startswith(field + " = ") and words in message and "\n" not in message


def test_fold_defaults_to_where_the_symmetry_is_exact():
    raw = {"material": ANISO, "incidence": {"theta_i_deg": [30, 30, 30], "phi_i_deg": [0, 45, 90]}}
    cfg = config_mod.validate(raw)
    assert [cfg.folds(d) for d in cfg.incidence] == [True, False, True]
    cfg = config_mod.validate({**raw, "simulation": {"fold_symmetry": False}})
    assert not any(cfg.folds(d) for d in cfg.incidence)
    assert config_mod.validate({"material": FIG7B, "simulation": {"max_paths": 2e9, "target_error": 0.1}}
                               ).max_paths == 2 * 10**9


# --- exact-f1 end to end -------------------------------------------------------------------

def test_exact_f1_table_holds_the_model_and_refuses_compare(tmp_path):
    """An exact-f1 run: f1 is the model's cell averages (its albedo within a z-test at 1e-3
    of the analog count), f_inf the model plus the binned orders >= 2, the first-order exits
    are counted, not binned, the table says which orders are analytic, `compare` refuses it."""
    from vcavity.cli import main
    from vcavity.io.writer import write_table
    from vcavity import open_table

    material = FIG7B
    raw = {"material": material, "incidence": {"theta_i_deg": [40.0], "paths": 300_000},
           "simulation": {"seed": 9, "max_order": 2, "sensor_resolution": 15, "estimator": "exact-f1"}}
    cfg = config_mod.validate(raw)
    from vcavity.simulate.pipeline import simulate

    exact = simulate(cfg)
    analog = simulate(config_mod.validate({**raw, "simulation": {**raw["simulation"], "estimator": "analog"}}))
    sensor = EqualAreaSensor(15)
    area = np.asarray(sensor.cell_projected_solid_angle)
    n = exact["paths"][0]
    assert np.all(exact["counts"][0, 1] == 0)
    # the same streams: the walk is the analog one, only its first-order exits are not binned
    f1_analog = analog["counts"][0, 1].sum()
    assert exact["unbinned_paths"][0] == f1_analog
    np.testing.assert_array_equal(exact["counts"][0, 2], analog["counts"][0, 2])
    np.testing.assert_array_equal(exact["counts"][0, 0], analog["counts"][0, 0] - analog["counts"][0, 1])
    p = f1_analog / n
    # the model's f1 albedo against the analog count: binomial z-test, 1e-3
    assert abs(exact["albedo"][0, 1] * n - f1_analog) < 3.3 * np.sqrt(n * p * (1 - p))
    mirror = mirror_cells(sensor, 0.0)
    merged = exact["counts"][0, 0] + np.where(mirror != np.arange(mirror.size), exact["counts"][0, 0][mirror], 0)
    halves = np.where(mirror != np.arange(mirror.size), 2.0, 1.0)
    np.testing.assert_allclose(exact["brdf"][0, 0], exact["brdf"][0, 1] + merged / (n * halves * area), rtol=1e-12)
    assert exact.attrs["model_error_ratio"] <= 0.1
    path = tmp_path / "exact.h5"
    write_table(path, exact)
    table = open_table(path)
    assert table.estimator == "exact-f1" and table.is_analytic(1) and table.is_analytic(0)
    assert not table.is_analytic(2)
    assert main(["compare", str(path)]) == 2
