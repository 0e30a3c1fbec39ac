"""Tests of the sub-cell quadrature (vcavity.analytic.quadrature; physics.md sections 6, 9).

Exact values come from the sensor's projected solid angles, which tests/sensor/test_grid.py
checks against an independent closed form and a brute-force midpoint rule.
"""

import numpy as np
import pytest

from vcavity.analytic.quadrature import subcell_quadrature
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sensor.binning import cell_index

RESOLUTIONS = [1, 2, 57, 100]


def cell_bounds(cell, resolution):
    ix, iy = cell % resolution, cell // resolution
    w = 2.0 / resolution
    return -1.0 + w * ix, -1.0 + w * (ix + 1), -1.0 + w * iy, -1.0 + w * (iy + 1)


def crosses_diagonal(cells, resolution):
    """True where |u| = |v| passes through the cell interior (integrand has a kink)."""
    u_lower, u_upper, v_lower, v_upper = cell_bounds(cells, resolution)
    min_abs_u = np.where(u_lower * u_upper < 0, 0.0, np.minimum(abs(u_lower), abs(u_upper)))
    min_abs_v = np.where(v_lower * v_upper < 0, 0.0, np.minimum(abs(v_lower), abs(v_upper)))
    max_abs_u = np.maximum(abs(u_lower), abs(u_upper))
    max_abs_v = np.maximum(abs(v_lower), abs(v_upper))
    return ~((min_abs_u >= max_abs_v) | (min_abs_v >= max_abs_u))


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_subcell_quadrature(resolution):
    sensor = EqualAreaSensor(resolution)
    exact = sensor.cell_projected_solid_angle
    kinked = crosses_diagonal(np.arange(sensor.n_cells), resolution)
    errors = {}
    for n_sub in (1, 2, 8, 16):
        directions, weights = subcell_quadrature(sensor, n_sub)
        assert directions.shape == (sensor.n_cells, n_sub * n_sub, 3)
        assert weights.shape == (sensor.n_cells, n_sub * n_sub) and np.all(weights > 0)
        np.testing.assert_allclose(weights.sum(axis=1), sensor.cell_solid_angle, rtol=1e-13)
        np.testing.assert_allclose(np.linalg.norm(directions, axis=2), 1.0, atol=1e-14)
        own_cell = cell_index(sensor, directions)
        np.testing.assert_array_equal(own_cell, np.broadcast_to(np.arange(sensor.n_cells)[:, None], own_cell.shape))
        relative_error = np.abs(np.sum(directions[..., 2] * weights, axis=1) - exact) / exact
        errors[n_sub] = relative_error
        if n_sub >= 2:
            # Off the diagonals cos theta is 1 - u^2 or 1 - v^2, a quadratic, which
            # n_sub >= 2 Gauss-Legendre points integrate exactly.
            assert np.all(relative_error[~kinked] < 1e-12)
        if n_sub >= 8:
            # Across |u| = |v| the gradient jumps; subcell_quadrature splits those cells
            # along both diagonals (n_sub >= 4), where cos theta is quadratic on each
            # triangle and integrated exactly (a plain tensor rule: ~0.8/n_sub^2).
            assert np.all(relative_error[kinked] < 1e-12)
    assert errors[16].max() < 1e-12


@pytest.mark.parametrize("resolution", [1, 2, 5, 8, 57])
@pytest.mark.parametrize("n_sub", [4, 5, 6, 7, 12])
def test_subcell_quadrature_crossed_cells_exact(resolution, n_sub):
    # Cells crossed by |u| = |v| (four-triangle Duffy rule) integrate cos theta to
    # round-off, for even and odd n_sub; weights stay >= 0 and nodes in their own cell.
    sensor = EqualAreaSensor(resolution)
    cells = np.flatnonzero(crosses_diagonal(np.arange(sensor.n_cells), resolution))
    directions, weights = subcell_quadrature(sensor, n_sub, cells=cells)
    exact = sensor.cell_projected_solid_angle[cells]
    np.testing.assert_allclose(np.sum(directions[..., 2] * weights, axis=1), exact, rtol=1e-10)
    np.testing.assert_allclose(weights.sum(axis=1), sensor.cell_solid_angle[cells], rtol=1e-13)
    ix, iy = cells % resolution, cells // resolution
    split = (ix == iy) | (ix + iy == resolution - 1)  # others only touch |u| = |v| at a corner
    assert np.all(weights >= 0) and np.count_nonzero(weights == 0) == (n_sub % 2) * np.count_nonzero(split)
    own_cell = cell_index(sensor, directions)
    assert np.all(own_cell == cells[:, None])
    if resolution == 57 and n_sub >= 8:
        # a smooth non-polynomial integrand converges fast too (reference: 64 x 64 rule;
        # measured 4e-8 at n_sub = 8, 9e-11 at 12)
        fine_dirs, fine_weights = subcell_quadrature(sensor, 64, cells=cells)
        def smooth(d):
            return np.exp(2.0 * d[..., 0] - d[..., 1]) * d[..., 2]
        reference = np.sum(smooth(fine_dirs) * fine_weights, axis=1)
        np.testing.assert_allclose(np.sum(smooth(directions) * weights, axis=1), reference, rtol=1e-7)


def test_subcell_quadrature_cell_subset_and_validation():
    sensor = EqualAreaSensor(57)
    subset = np.array([3248, 0, 1624, 7])
    directions, weights = subcell_quadrature(sensor, 4, cells=subset)
    all_directions, all_weights = subcell_quadrature(sensor, 4)
    np.testing.assert_array_equal(directions, all_directions[subset])
    np.testing.assert_array_equal(weights, all_weights[subset])
    for bad_cells in ([-1], [3249], [0.5]):
        with pytest.raises(ValueError):
            subcell_quadrature(sensor, 4, cells=np.array(bad_cells))
    for bad_n_sub in (0, 2.0):
        with pytest.raises(ValueError):
            subcell_quadrature(sensor, bad_n_sub)
