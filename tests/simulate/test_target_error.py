"""Target-error runs: the stop rule, its reproducibility and the path cap (simulate.py)."""

import subprocess
import sys

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity.rng import BLOCK_SIZE
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import TARGET_CHECK_BLOCKS, simulate

MATERIAL = {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5}
STEP = TARGET_CHECK_BLOCKS * BLOCK_SIZE


def _config(target, cap, fold=None, theta=(30.0, 70.0)):
    return config_mod.validate({
        "material": MATERIAL,
        "incidence": {"theta_i_deg": list(theta), "paths": cap},
        "simulation": {"seed": 5, "max_order": 2, "sensor_resolution": 15, "target_error": target,
                       "fold_symmetry": fold}})


def _energy_weighted_error(result, j):
    """The stop rule's measure, recomputed from the table values: sum sigma Omega / sum f Omega."""
    area = np.asarray(EqualAreaSensor(result.attrs["sensor_resolution"]).cell_projected_solid_angle)
    return np.sum(result["brdf_stderr"][j, 0] * area) / np.sum(result["brdf"][j, 0] * area)


def test_stops_at_the_first_check_below_the_target():
    result = simulate(_config(0.01, 10**8))
    assert np.all(result["target_reached"])
    for j in range(2):
        paths = int(result["paths"][j])
        assert paths % STEP == 0 and 3 * STEP <= paths < 10**8
        error = _energy_weighted_error(result, j)
        assert error == pytest.approx(result["relative_error"][j], rel=1e-12) and error <= 0.01
        # one check earlier (the same streams, a fixed budget) the error was above the target
        earlier = simulate(config_mod.validate({
            "material": MATERIAL,
            "incidence": {"theta_i_deg": [30.0, 70.0][j], "paths": paths - STEP},
            "simulation": {"seed": 5, "max_order": 2, "sensor_resolution": 15}}))
        assert earlier["relative_error"][0] > 0.01


def test_same_table_for_any_threads_and_chunking():
    first = simulate(_config(0.03, 10**8), threads=1, chunk_blocks=5)
    second = simulate(_config(0.03, 10**8), chunk_blocks=512)
    np.testing.assert_array_equal(first["paths"], second["paths"])
    np.testing.assert_array_equal(first["counts"], second["counts"])
    np.testing.assert_array_equal(first["brdf"], second["brdf"])


def test_path_cap_is_reported():
    cap = 300_000  # not a multiple of the check step: the last block is short
    result = simulate(_config(1e-4, cap))
    np.testing.assert_array_equal(result["paths"], [cap, cap])
    assert not np.any(result["target_reached"])
    assert np.all(result["relative_error"] > 1e-4)


def test_fold_reaches_the_target_with_fewer_paths():
    folded = simulate(_config(0.03, 10**8, fold=None, theta=(60.0,)))
    unfolded = simulate(_config(0.03, 10**8, fold=False, theta=(60.0,)))
    assert folded["paths"][0] < unfolded["paths"][0]


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "vcavity.cli", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=600)


def test_cli_target_error_and_cap(tmp_path):
    config = tmp_path / "run.toml"
    config.write_text('[material]\ndistribution = "beckmann"\nalpha = 0.6\nkd = 0.9\n'
                      '[incidence]\ntheta_i_deg = [45]\n[simulation]\nsensor_resolution = 15\n')
    done = _cli("run", str(config), "-o", "t.h5", "-q", "--target-error", "0.05", "--max-paths", "2e6",
                cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "target error 0.05 reached" in done.stdout
    capped = _cli("run", str(config), "-o", "c.h5", "-q", "--target-error", "0.0001", "--max-paths", "100000",
                  cwd=tmp_path)
    assert capped.returncode == 0 and "NOT reached: path cap hit" in capped.stdout
    from vcavity import open_table

    table = open_table(tmp_path / "c.h5")
    assert table.paths[0] == 100_000 and table.target_reached[0] == 0
    assert table.attrs["target_error"] == pytest.approx(1e-4)


@pytest.mark.parametrize("args, words", [
    (["--max-paths", "1000"], "--max-paths = 1000: applies only with --target-error"),
    (["--target-error", "2"], "expected a number in (0, 1)"),
    (["--estimator", "paperish"], "invalid choice"),
])
def test_cli_bad_flags(tmp_path, args, words):
    done = _cli("run", "-o", "x.h5", "-q", *args, cwd=tmp_path)
    assert done.returncode == 2 and words in done.stderr
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.parametrize("cap", [1, 2, 7])
def test_a_few_landed_paths_do_not_reach_a_target(cap):
    """One path traced and landed in one cell has a binomial error of exactly 0: that is no
    error estimate, so the target (0.01 needs >= 1 / (2 0.01^2) = 5000 landed paths) is not
    reached and the direction stops at its cap."""
    result = simulate(_config(0.01, cap))
    np.testing.assert_array_equal(result["paths"], [cap, cap])
    assert not np.any(result["target_reached"])


def test_the_landed_paths_rule_changes_no_honest_estimate():
    """The rule's bound (estimators.error_estimate_exists): with no cell holding more than
    half of N paths, sum_c sqrt(n_c (1 - n_c/N)) / sum_c n_c >= 1 / sqrt(2 n), so a relative
    error <= E implies n >= 1 / (2 E^2) landed paths. Checked in plain NumPy on random
    multinomial counts (seeded) of many shapes, including lobes in few cells."""
    from vcavity.estimators.counts import error_estimate_exists

    rng = np.random.default_rng(11)
    for _ in range(2000):
        n_cells = int(rng.integers(2, 200))
        paths = int(rng.integers(1, 10**6))
        shares = rng.dirichlet(np.full(n_cells, rng.choice([0.05, 1.0, 20.0])))
        shares *= rng.uniform(0.05, 1.0)  # the rest is absorbed
        counts = rng.multinomial(paths, np.append(shares, 1.0 - shares.sum()))[:-1]
        if counts.sum() == 0 or counts.max() > paths / 2:
            continue
        error = np.sum(np.sqrt(counts * (1.0 - counts / paths))) / counts.sum()
        assert error_estimate_exists(int(counts.sum()), error * (1 + 1e-12))
    assert not error_estimate_exists(1, 0.01) and error_estimate_exists(5000, 0.01)
