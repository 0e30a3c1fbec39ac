"""A written table's values in 1/sr, end to end through the command line.

``python -m vcavity run CONFIG -o T.h5 -q`` on a mirror material (so f1 and f2 both
have independent references), then ``vcavity.open_table(T)``: the stored ``brdf`` (not
the counts) is converted back with OUR projected solid angles (closed form,
tests/reference/sensor.py) into ``n_c = brdf_c Ω⊥_c paths`` and

1. every ``n_c`` must be an integer to 1e-6 (the table divides integer counts by
   ``paths Ω⊥_c``; any other solid angle or normalisation anywhere gives non-integers);
2. ``n_c`` must pass Pearson chi-square and the albedo z-test against the reference
   ``paths P_c`` of f1 (tests/reference/single_bounce.py) and f2
   (tests/reference/groove_paths.py), so that a consistent wrong scale fails too.

Written against the CLI and ``vcavity.open_table`` (``.brdf``, ``.order``, ``.paths``)
only, because the table writer is being reworked (format v2). False positives: Sidak
over 2 directions x 2 orders x 2 tests, family-wise 1 %; the integrality check is exact.
"""

import os
import subprocess
import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

import numpy as np  # noqa: E402

import vcavity  # noqa: E402
from tests.reference import groove_paths as ref_groove  # noqa: E402
from tests.reference import materials as ref_mat  # noqa: E402
from tests.reference import sensor as ref_sensor  # noqa: E402
from tests.reference import single_bounce as ref_sb  # noqa: E402
from tests.validation._reference_runs import assert_pass, incident, sidak_threshold, verdicts  # noqa: E402

MATERIAL = {"distribution": "beckmann", "alpha": 0.6, "facet": "mirror"}
THETAS = (0.0, 50.0)
PHI = 30.0
PATHS = 400_000
RESOLUTION = 9
LEVEL = sidak_threshold(0.01, 2 * 2 * len(THETAS))

CONFIG = f"""
[material]
distribution = "beckmann"
alpha = 0.6
facet = "mirror"

[incidence]
theta_i_deg = [{THETAS[0]}, {THETAS[1]}]
phi_i_deg = {PHI}
paths = {PATHS}

[simulation]
seed = 7301
max_order = 2
sensor_resolution = {RESOLUTION}
"""


def test_table_brdf_is_counts_over_paths_and_projected_solid_angle(tmp_path):
    config = tmp_path / "run.toml"
    config.write_text(CONFIG, encoding="utf-8")
    out = tmp_path / "T.h5"
    proc = subprocess.run([sys.executable, "-m", "vcavity", "run", str(config), "-o", str(out), "-q"],
                          capture_output=True, text=True, cwd=tmp_path, env=dict(os.environ), timeout=600)
    assert proc.returncode == 0, f"vcavity run failed ({proc.returncode}):\n{proc.stderr}"
    table = vcavity.open_table(out)
    assert list(np.asarray(table.order)) == [0, 1, 2]
    assert np.all(np.asarray(table.paths) == PATHS)
    projected = ref_sensor.projected_solid_angle(RESOLUTION)
    material = ref_mat.parse_material(MATERIAL)
    brdf = np.asarray(table.brdf)
    assert brdf.shape == (len(THETAS), 3, RESOLUTION * RESOLUTION)
    for d, theta in enumerate(THETAS):
        i = incident(theta, PHI)
        groove, _ = ref_groove.groove_orders(material, i, RESOLUTION, 2, 128, 256, 8)
        references = {1: ref_sb.f1_cells(material, i, RESOLUTION), 2: groove[1]}
        for k, p in references.items():
            slot = int(np.flatnonzero(np.asarray(table.order) == k)[0])
            n = brdf[d, slot] * projected * PATHS
            off = np.abs(n - np.round(n))
            assert off.max() <= 1e-6 * max(1.0, n.max()), (
                f"theta_i {theta}, f{k}: brdf * Ω⊥ * paths is not an integer count "
                f"(worst {off.max():.3g} at cell {int(off.argmax())}): wrong solid angle or normalisation")
            chi, z = verdicts(n, p, PATHS)
            assert_pass(chi, z, LEVEL, f"table brdf, theta_i {theta}, f{k}")
