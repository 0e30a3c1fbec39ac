"""The exact-f1 model's peak cells (vcavity/analytic/peak_cells.py, exact_f1.py, specular_peak.py):
the scan's choice of cells and the peak rays' radial error estimate keep the model's bound.

- The scan leaves a cell to the sub-cell rule only where that rule is good to the cell's
  estimate: in every cell it leaves unmarked, ``f1_cell_integrals`` with the scan's cells
  agrees with the same model with *every* cell integrated by the peak rays, within the sum
  of both error estimates. Narrow lobes where the scan matters: a Beckmann 0.05 lobe at
  60 deg (narrower than a cell), a grazing wedge (Beckmann 0.02 at 89 deg) and an
  anisotropic ridge (alpha_y = 0.01).
- The peak rays' error estimate includes the radial rule's: at ``n_radial = 2`` the
  estimate bounds, per cell, the difference to ``n_radial = 64`` (whose own estimate is
  added as its uncertainty), and the coarse rule is measurably worse than the fine one.

Deterministic quadratures: no false-positive rate. The reference of each comparison is
the same model with a stronger rule (all cells by rays; 32 x the radial nodes), so what
is tested is the honesty of the estimate and of the cell choice, not the model (which
tests/analytic/test_specular_peak.py and test_exact_f1.py hold against plain-NumPy
references).
"""

import math

import numpy as np
import pytest

from vcavity.analytic import SingleBounceModel, exact_f1
from vcavity.analytic.exact_f1 import ROUNDOFF, f1_cell_integrals
from vcavity.analytic.peak_cells import peak_cells
from vcavity.analytic.specular_peak import peak_integrals
from vcavity.config import validate
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import incident_vector

DIELECTRIC = {"facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5}
CASES = {
    "narrow-60": ({"distribution": "beckmann", "alpha": 0.05}, 60.0),
    "wedge-89": ({"distribution": "beckmann", "alpha": 0.02}, 89.0),
    "ridge-40": ({"distribution": "beckmann", "alpha_x": 0.3, "alpha_y": 0.01}, 40.0),
}
#: per-cell tolerance: a tenth of the standard error of a cell of 1e-3 of the light at 1e9 paths
TOLERANCE = 1e-7


def _case(name):
    raw, theta_deg = CASES[name]
    material = validate({"material": dict(DIELECTRIC, **raw)}).material
    return material, incident_vector(math.radians(theta_deg), math.radians(10.0)), EqualAreaSensor(17)


@pytest.mark.parametrize("name", sorted(CASES))
def test_cells_the_scan_leaves_unmarked_keep_their_bound(name, monkeypatch):
    material, incident, sensor = _case(name)
    marked = peak_cells(SingleBounceModel(material), incident, sensor)
    assert 0 < marked.size < sensor.n_cells // 2
    values, error = f1_cell_integrals(material, incident, sensor, TOLERANCE)
    monkeypatch.setattr(exact_f1, "peak_cells", lambda model, i, s: np.arange(s.n_cells))
    all_values, all_error = f1_cell_integrals(material, incident, sensor, TOLERANCE)
    unmarked = np.setdiff1d(np.arange(sensor.n_cells), marked)
    difference = np.abs(values - all_values)[unmarked]
    bound = (error + all_error)[unmarked]
    worst = int(np.argmax(difference - bound))
    assert np.all(difference <= bound), (unmarked[worst], difference[worst], bound[worst])
    assert np.all(error <= TOLERANCE)
    # the scan's cells are where the lobe is: the unmarked cells hold little of it
    assert values[unmarked].sum() < 0.5 * values.sum()


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_peak_rays_estimate_bounds_a_coarse_radial_rule(name):
    material, incident, sensor = _case(name)
    model = SingleBounceModel(material)
    cells = peak_cells(model, incident, sensor)
    coarse, coarse_error = peak_integrals(model, incident, sensor, cells, n_radial=2, with_error=True)
    fine, fine_error = peak_integrals(model, incident, sensor, cells, n_radial=64, with_error=True)
    actual = np.abs(coarse - fine)
    roundoff = ROUNDOFF * fine.max()  # the model's own floor of an estimate (exact_f1._total)
    bound = coarse_error + fine_error + roundoff
    worst = int(np.argmax(actual - bound))
    assert np.all(actual <= bound), (cells[worst], actual[worst], bound[worst])
    assert actual.sum() > fine_error.sum() and actual.max() > 10 * roundoff  # the coarse rule is measurably worse
