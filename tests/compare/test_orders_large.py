"""``vcavity compare --order K`` on a table of 1e9 paths per direction (vcavity/compare/orders.py).

Tracing 1e9 paths per direction is too slow for a test, so the table is drawn: a mirror
V-cavity's every-order cell probabilities on one fixed 2048 x 2048 mesh (no refinement
loop; at least 4 x finer per side than the default tolerance's mesh, its error ~1e-5
relative L1, 30 x below the noise of 1e9 paths), and per direction one multinomial draw
of 1e9 paths over (order 1, order 2, orders beyond 2) x cell and "no exit", in plain
NumPy with a fixed seed, written as an analog table (tests/io/tables.py). That is what
a correct simulator's table is, so compare must PASS it:

- the per-test level is the Sidak level of the table's 2 x directions tests,
  ``1 - (1 - alpha)^(1/m)``, computed here and read from the printed report, and each
  printed verdict follows its printed p-value at that level;
- the model is refined until its error estimate is at most a tenth of the noise (read
  from the report); a model left at the default tolerance (1e-3 relative) is off by about
  the noise of 1e9 paths, and the chi-square fails it (planted: no refinement).

False-positive rate of the PASS: 1 % (the family level) per order, for this fixed seed. The
default suite tests f1 (~20 s); f_inf is under the slow marker.
"""

import re

import numpy as np
import pytest

from tests.io.tables import analog_table
from vcavity.analytic.specular_orders import specular_orders
from vcavity.cli import main
from vcavity.config import validate
from vcavity.io.table import write_table
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor

MIRROR = {"distribution": "beckmann", "alpha": 0.5, "facet": "mirror"}
THETA_DEG, PHI_DEG = [0.0, 70.0], 20.0
PATHS = 10**9
MAX_ORDER, MAX_BOUNCES, RESOLUTION = 2, 10_000, 17
TRUTH_QUADS = 2048
FAMILY_LEVEL = 0.01


@pytest.fixture(scope="module")
def large_table(tmp_path_factory):
    material = validate({"material": MIRROR}).material
    sensor = EqualAreaSensor(RESOLUTION)
    rng = np.random.default_rng(2026_12_05)
    theta, phi = np.radians(THETA_DEG), np.full(len(THETA_DEG), np.radians(PHI_DEG))
    counts = np.zeros((theta.size, MAX_ORDER + 1, sensor.n_cells), dtype=np.int64)
    lost = np.zeros(theta.size, dtype=np.int64)
    for j in range(theta.size):
        truth = specular_orders(material, incident_vector(theta[j], phi[j]), sensor, MAX_ORDER, MAX_BOUNCES,
                                tolerance=np.inf, start_quads=TRUTH_QUADS)
        p = np.clip(truth.integrals.ravel(), 0.0, None)  # rows: order 1, order 2, orders > 2
        drawn = rng.multinomial(PATHS, np.append(p, max(0.0, 1.0 - p.sum())) / max(1.0, p.sum()))
        rows = drawn[:-1].reshape(MAX_ORDER + 1, sensor.n_cells)
        counts[j, 0] = rows.sum(axis=0)  # f_inf
        counts[j, 1:] = rows[:MAX_ORDER]
        lost[j] = drawn[-1]
    zeros = np.zeros(theta.size, dtype=np.int64)
    path = tmp_path_factory.mktemp("orders_large") / "mirror_1e9.h5"
    config = {"simulation": {"max_order": MAX_ORDER, "max_bounces": MAX_BOUNCES, "track_all_orders": True,
                             "sensor_resolution": RESOLUTION}}
    write_table(path, analog_table(theta_i=theta, phi_i=phi, order=[0, 1, 2], counts=counts,
                                   paths=np.full(theta.size, PATHS), absorbed_paths=zeros, truncated_paths=lost,
                                   degenerate_paths=zeros, max_bounces_seen=zeros + 50, sensor=sensor,
                                   material=material.to_dict(), config=config, seed=0, max_bounces=MAX_BOUNCES,
                                   theta_i_deg=THETA_DEG, phi_i_deg=[PHI_DEG] * theta.size))
    return path


def _number(text):
    return float(text.replace(",", ""))


@pytest.mark.parametrize("order", ["1", pytest.param("inf", marks=pytest.mark.slow)])
def test_a_correct_1e9_path_table_passes_with_the_sidak_level_and_a_refined_model(large_table, capsys, order):
    assert main(["compare", str(large_table), "--order", order, "--significance", str(FAMILY_LEVEL)]) == 0, \
        capsys.readouterr().out
    out = capsys.readouterr().out
    assert "result: PASS" in out
    # the per-test level: Sidak over 2 tests (chi-square, albedo z) per direction
    tests = 2 * len(THETA_DEG)
    level = 1.0 - (1.0 - FAMILY_LEVEL) ** (1.0 / tests)
    printed = re.search(r"family level ([0-9.e+-]+) \(Sidak: ([0-9.e+-]+) per test\)", out)
    assert printed is not None, out
    assert float(printed.group(1)) == FAMILY_LEVEL
    assert float(printed.group(2)) == pytest.approx(level, rel=5e-3), (printed.group(2), level)
    verdicts = re.findall(r"p = ([0-9.e+-]+)\s+(?:\([^)]*\)\s+)?-> (pass|FAIL)", out)
    assert len(verdicts) == tests, out
    for p_value, verdict in verdicts:
        if abs(float(p_value) / level - 1.0) > 0.01:  # printed to 3-4 digits
            assert (verdict == "pass") == (float(p_value) >= level), (p_value, verdict, level)
    # the model refined to a tenth of the noise of 1e9 paths
    rows = re.findall(r"noise alone: ([0-9.e+-]+); model error estimate ([0-9.e+-]+), (\d+) x \d+ mesh", out)
    assert len(rows) == len(THETA_DEG), out
    for noise, model_error, quads in rows:
        assert _number(model_error) <= 0.1 * _number(noise) * 1.01, (noise, model_error, quads)
