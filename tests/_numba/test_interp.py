"""vcavity/_numba/interp.py against NumPy's own ``np.interp`` (the reference; plain NumPy, not
jitted): equal bit for bit at random points, at and between nodes, outside the table, at
infinities and NaN, on tables with a flat and an infinite stretch. Deterministic (seed 5)."""

import math

import numpy as np
import pytest

from vcavity._numba.interp import interp

TABLES = {
    "grid": (np.linspace(0.0, 3.0, 2048), np.sqrt(np.linspace(0.0, 3.0, 2048)) * np.cos(np.linspace(0.0, 9.0, 2048))),
    "uneven": (np.array([0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 1e300]),
               np.log(np.array([0.3, 0.2, 0.1, 0.05, 0.02, 1e-3, 1e-5, 1e-300]))),
    "two nodes": (np.array([-1.0, 2.0]), np.array([4.0, -0.5])),
    "one node": (np.array([0.5]), np.array([7.0])),
    "flat and infinite": (np.array([0.0, 1.0, 2.0, 3.0]), np.array([math.inf, math.inf, 1.0, -math.inf])),
}


@pytest.mark.parametrize("name", TABLES)
def test_equal_to_numpy_bit_for_bit(name):
    xp, fp = TABLES[name]
    rng = np.random.default_rng(5)
    span = xp[-1] - xp[0] if xp.size > 1 and np.isfinite(xp[-1] - xp[0]) else 4.0
    points = np.concatenate([
        xp, 0.5 * (xp[1:] + xp[:-1]), np.nextafter(xp, -np.inf), np.nextafter(xp, np.inf),
        xp[0] + span * rng.uniform(-0.2, 1.2, 500), [-math.inf, math.inf, math.nan, -1e308, 1e308, 0.0, -0.0]])
    got = np.array([interp(float(x), xp, fp) for x in points])
    expected = np.array([np.interp(x, xp, fp) for x in points])
    same = (got == expected) | (np.isnan(got) & np.isnan(expected))
    assert same.all(), [(x, g, e) for x, g, e, s in zip(points, got, expected, same) if not s][:5]
    assert np.array_equal(np.signbit(got[~np.isnan(got)]), np.signbit(expected[~np.isnan(expected)]))
