"""The fast binning paths (direction_to_cell, and bin_block over a block of exits) are
identical to binning the exact inverse map."""

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does

from vcavity.sensor.binning import (
    _ATAN_MAX_ERROR,
    _atan_unit_fast,
    _square_coordinate_to_bin,
    bin_block,
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


# offsets from a bin edge, in square coordinates: on it, within round-off, within the fast
# atan's error (2e-8) and beyond
EDGE_OFFSETS = np.array([0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 3e-8, -3e-8, 1e-6, -1e-6])


def _random_directions(seed, n):
    """``n`` directions uniform over the upper hemisphere."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0, 1, n)
    phi = rng.uniform(0, 2 * np.pi, z.size)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


@pytest.mark.parametrize("resolution", [1, 2, 7, 57, 400])
def test_fast_binning_is_identical_to_exact_binning(resolution):
    for directions in (_random_directions(31, 400_000), _edge_directions(resolution, EDGE_OFFSETS)):
        fast, exact = _both(directions, resolution)
        np.testing.assert_array_equal(fast, exact)


def _awkward_directions():
    """What the walk can hand the binning besides unit vectors: the pole, zero and
    non-finite vectors, z below 0 or above 1 (both clamped), |d| off 1, ties |x| = |y|,
    subnormal components."""
    tiny = 5e-324
    rows = [(0, 0, 1), (0, 0, 0), (-0.0, 0.0, 1), (np.nan, 0, 1), (0, np.nan, 1), (1, np.nan, 0),
            (np.nan, np.nan, np.nan), (0.6, 0.8, np.nan), (np.inf, 0, 0), (0, -np.inf, 0), (1e-300, 0, 1),
            (0, -1e-300, 1), (tiny, tiny, 1), (-tiny, 0, 1), (0.5, 0.5, 0.5 ** 0.5), (-0.5, 0.5, 0.5 ** 0.5),
            (0.5, -0.5, 0.5 ** 0.5), (-0.5, -0.5, 0.5 ** 0.5), (1, 0, -1e-17), (0.6, 0.8, -1e-3),
            (0, 0, 1 + 2e-16), (2, 0, 0), (0, 0, 2), (0.3, 0.4, 1.5), (-0.3, 0.4, -0.5), (0.6 * (1 + 4e-16), 0.8, 0)]
    return np.array(rows, dtype=np.float64)


@pytest.mark.parametrize("resolution", [1, 2, 7, 57, 400])
def test_block_binning_is_identical_to_direction_to_cell(resolution):
    """bin_block (branch-free, vectorised) bins every direction exactly as direction_to_cell."""
    edges = _edge_directions(resolution, EDGE_OFFSETS)
    directions = np.concatenate([_awkward_directions(), _random_directions(32, 200_000), edges, edges * (1 + 3e-16)])
    fast, _exact = _both(directions, resolution)
    xs, ys, zs = (np.ascontiguousarray(directions[:, k]) for k in range(3))
    cells = np.empty(directions.shape[0], np.int64)
    bin_block(xs, ys, zs, directions.shape[0], resolution, cells)
    np.testing.assert_array_equal(cells, fast)


def test_block_binning_writes_only_the_first_n():
    directions = np.tile(_awkward_directions()[:1], (10, 1))
    xs, ys, zs = (np.ascontiguousarray(directions[:, k]) for k in range(3))
    cells = np.full(10, -7, np.int64)
    bin_block(xs, ys, zs, 4, 57, cells)
    assert list(cells) == [28 * 57 + 28] * 4 + [-7] * 6
