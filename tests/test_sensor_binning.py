"""The fast binning path of direction_to_cell is identical to binning the exact inverse map."""

import numpy as np
import pytest
from numba import njit

from vcavity.binning import (
    _ATAN_MAX_ERROR,
    _atan_unit_fast,
    _square_coordinate_to_bin,
    direction_to_cell,
    hemisphere_to_square,
    square_to_hemisphere,
)


@njit(cache=True)
def _both(directions, resolution):
    fast = np.empty(directions.shape[0], np.int64)
    exact = np.empty(directions.shape[0], np.int64)
    for k in range(directions.shape[0]):
        x, y, z = directions[k, 0], directions[k, 1], directions[k, 2]
        fast[k] = direction_to_cell(x, y, z, resolution)
        u, v = hemisphere_to_square(x, y, z)
        exact[k] = _square_coordinate_to_bin(v, resolution) * resolution + _square_coordinate_to_bin(u, resolution)
    return fast, exact


@njit(cache=True)
def _atan_error(t):
    err = 0.0
    for k in range(t.shape[0]):
        err = max(err, abs(_atan_unit_fast(t[k]) - np.arctan(t[k])))
    return err


def test_polynomial_atan_error_bound():
    t = np.linspace(-1.0, 1.0, 4_000_001)
    assert _atan_error(t) < _ATAN_MAX_ERROR


@njit(cache=True)
def _edge_directions(resolution, offsets):
    """Directions whose square coordinates sit on, or just beside, every bin edge."""
    n_edges = resolution + 1
    out = np.empty((n_edges * offsets.shape[0] * 7, 3))
    k = 0
    for e in range(n_edges):
        edge = -1.0 + 2.0 * e / resolution
        for off in offsets:
            t = min(max(edge + off, -1.0), 1.0)
            for other in (-0.93, -0.41, -0.05, 0.0, 0.33, 0.77, 1.0):
                if k % 2 == 0:
                    x, y, z = square_to_hemisphere(other, t)
                else:
                    x, y, z = square_to_hemisphere(t, other)
                out[k, 0], out[k, 1], out[k, 2] = x, y, z
                k += 1
    return out[:k]


@pytest.mark.parametrize("resolution", [1, 2, 7, 57, 400])
def test_fast_binning_is_identical_to_exact_binning(resolution):
    rng = np.random.default_rng(31)
    z = rng.uniform(0, 1, 400_000)
    phi = rng.uniform(0, 2 * np.pi, z.size)
    r = np.sqrt(1 - z * z)
    random = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    offsets = np.array([0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 3e-8, -3e-8, 1e-6, -1e-6])
    for directions in (random, _edge_directions(resolution, offsets)):
        fast, exact = _both(directions, resolution)
        np.testing.assert_array_equal(fast, exact)
