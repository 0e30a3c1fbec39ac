"""The conductor Fresnel reflectance (vcavity/facet/fresnel_conductor.py; physics.md sec. 4)
against an independent reference (tests/reference/conductor_fresnel.py: the textbook form in
NumPy extended-precision complex arithmetic) and its limits: normal incidence, grazing
incidence, k = 0 (the dielectric F), large k, bounds. Deterministic (no false-positive rate).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.reference import conductor_fresnel as reference  # noqa: E402
from vcavity.facet.fresnel import fresnel_dielectric_array  # noqa: E402
from vcavity.facet.fresnel_conductor import fresnel_conductor, fresnel_conductor_array  # noqa: E402

ETAS = np.geomspace(0.05, 10.0, 61)
KS = np.concatenate([[0.0], np.geomspace(1e-3, 20.0, 40)])
COSINES = np.concatenate([np.linspace(0.0, 1.0, 1001), np.geomspace(1e-8, 1.0, 200)])


def _relative_errors(eta, k):
    exact = reference.fresnel_conductor(COSINES, eta, k)
    return np.abs(fresnel_conductor_array(COSINES, eta, k) - exact) / exact


@pytest.mark.skipif(not reference.EXTENDED, reason="the reference needs np.longdouble wider than float64")
def test_matches_the_complex_arithmetic_reference_on_a_wide_grid():
    # Measured worst: 1.6e-14 (k = 0, eta = 0.497, 7e-5 from the critical angle, where
    # F has an infinite derivative); 3.0e-15 for every k > 0.
    worst_dielectric = worst_conductor = 0.0
    for eta in ETAS:
        for k in KS:
            worst = float(np.max(_relative_errors(eta, k)))
            if k == 0.0:
                worst_dielectric = max(worst_dielectric, worst)
            else:
                worst_conductor = max(worst_conductor, worst)
    assert worst_conductor < 5e-15, worst_conductor
    assert worst_dielectric < 2e-14, worst_dielectric


def test_normal_incidence_is_the_closed_form():
    for eta in ETAS:
        for k in KS:
            expected = ((eta - 1.0) ** 2 + k * k) / ((eta + 1.0) ** 2 + k * k)
            assert fresnel_conductor(1.0, eta, k) == pytest.approx(expected, rel=2e-15, abs=1e-300)


def test_grazing_incidence_reflects_everything():
    for eta in np.concatenate([ETAS, [1e-6, 1e6]]):
        for k in np.concatenate([KS, [1e6]]):
            if eta == 1.0 and k == 0.0:
                continue
            assert fresnel_conductor(0.0, eta, k) == 1.0
            # and F approaches 1 continuously: 1 - F = O(c) near grazing
            assert 1.0 - fresnel_conductor(1e-12, eta, k) < 1e-9 * max(1.0, eta + k)


def test_no_interface_reflects_nothing():
    assert np.all(fresnel_conductor_array(COSINES, 1.0, 0.0) == 0.0)


@pytest.mark.parametrize("eta", [1.0 + 1e-6, 1.0001, 1.33, 1.5, 2.5, 10.0, 1000.0])
def test_zero_extinction_is_the_dielectric_fresnel(eta):
    dielectric = fresnel_dielectric_array(COSINES, eta)
    conductor = fresnel_conductor_array(COSINES, eta, 0.0)
    np.testing.assert_allclose(conductor, dielectric, rtol=4e-15, atol=1e-300)


def test_large_extinction_reflects_almost_everything():
    c = np.linspace(0.01, 1.0, 100)
    for eta in (0.05, 0.43, 1.0, 3.0):
        previous = np.zeros_like(c)
        for k in (10.0, 1e2, 1e4, 1e8):
            f = fresnel_conductor_array(c, eta, k)
            # 1 - R_s ~ 4 eta c/k^2 and 1 - R_p ~ 4 eta/(k^2 c) for k >> eta, 1
            assert np.all(1.0 - f <= 10.0 * eta / (k * k * c) + 1e-15)  # + a few ulp of 1
            assert np.all(f >= previous)
            previous = f
    assert fresnel_conductor(0.5, 1.0, 1e200) == 1.0 and fresnel_conductor(0.5, 1e300, 1e300) <= 1.0


def test_bounded_and_finite_for_every_input():
    rng = np.random.default_rng(11)
    eta = 10.0 ** rng.uniform(-300, 300, 20_000)
    k = np.where(rng.uniform(size=eta.size) < 0.1, 0.0, 10.0 ** rng.uniform(-300, 300, eta.size))
    c = np.where(rng.uniform(size=eta.size) < 0.5, rng.uniform(size=eta.size), 10.0 ** rng.uniform(-300, 0, eta.size))
    f = np.array([fresnel_conductor(ci, ei, ki) for ci, ei, ki in zip(c, eta, k)])
    assert np.all(np.isfinite(f)) and np.all((f >= 0.0) & (f <= 1.0))
    # typical metals from the far UV to the infrared, every cosine
    for eta_i, k_i in ((0.43, 2.455), (0.14, 3.697), (1.38, 1.914), (0.05, 20.0), (10.0, 20.0), (3.0, 0.01)):
        f = fresnel_conductor_array(np.linspace(0.0, 1.0, 10_001), eta_i, k_i)
        assert np.all((f >= 0.0) & (f <= 1.0))


def test_array_version_is_the_scalar_elementwise():
    c = np.linspace(-1.0, 1.0, 21).reshape(3, 7)  # |cos| is taken
    out = fresnel_conductor_array(c, 0.43, 2.455)
    assert out.shape == c.shape and out.dtype == np.float64
    assert np.all(out == np.vectorize(lambda x: fresnel_conductor(x, 0.43, 2.455))(c))
    assert fresnel_conductor(1.0 + 1e-15, 0.43, 2.455) == fresnel_conductor(1.0, 0.43, 2.455)
