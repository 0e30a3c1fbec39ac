"""End to end: the Student-t distribution through the simulator, as a user runs it.

``vcavity run`` on Student-t configs and ``vcavity compare`` on the tables (f1 against
the V-cavity single-bounce model: cell chi-square and albedo z-test at a family level of
1 %, so each comparison has a 1 % false-alarm rate at its fixed seed), at two
roughnesses (one anisotropic, at phi_i = 0 and 90 deg); and the white furnace: with
``kd = 1`` nothing is absorbed, so every path exits or is truncated, exactly.
"""

import subprocess
import sys

import numpy as np
import pytest

from vcavity.config import validate
from vcavity.microfacet import registry
from vcavity.simulate.pipeline import simulate

pytestmark = pytest.mark.skipif("student_t" not in registry.NAMES, reason="student_t not registered")

CASES = {
    "smooth": 'alpha = 0.25\ngamma = 1.8',
    "rough-anisotropic": 'alpha_x = 0.9\nalpha_y = 0.4\ngamma = 4.0',
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_run_and_compare_pass(tmp_path, case):
    config = tmp_path / "st.toml"
    config.write_text(f"""[material]
distribution = "student_t"
{CASES[case]}
facet = "interfaced_lambertian"
kd = 0.7
eta = 1.5
[incidence]
theta_i_deg = [20, 65]
phi_i_deg = [0, 90]
paths = 400000
[simulation]
seed = 3
sensor_resolution = 15
""")
    run = subprocess.run([sys.executable, "-m", "vcavity", "run", str(config), "-o", str(tmp_path / "t.h5"), "-q"],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    compare = subprocess.run([sys.executable, "-m", "vcavity", "compare", str(tmp_path / "t.h5")],
                             capture_output=True, text=True, timeout=900)
    assert compare.returncode == 0, compare.stdout + compare.stderr
    assert "result: PASS" in compare.stdout


def test_white_furnace_is_exact():
    cfg = validate({
        "material": {"distribution": "student_t", "alpha_x": 0.5, "alpha_y": 1.2, "gamma": 2.5,
                     "facet": "interfaced_lambertian", "kd": 1.0, "eta": 1.5},
        "incidence": {"theta_i_deg": [0.0, 50.0, 85.0], "phi_i_deg": [0.0, 30.0, 90.0], "paths": 100_000},
        "simulation": {"seed": 9, "max_order": 2, "sensor_resolution": 9},
    })
    result = simulate(cfg)
    assert result["absorbed"].tolist() == [0, 0, 0]
    exits = result["counts"][:, 0, :].sum(axis=1)  # order 0: every exit
    lost = np.rint((result["truncated"] + result["degenerate"]) * result["paths"]).astype(np.int64)  # paths
    assert (exits + lost == result["paths"]).all()
    assert (lost <= 20).all()  # rare at this roughness
