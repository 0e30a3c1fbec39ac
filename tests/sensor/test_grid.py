"""Tests of the equal-solid-angle sensor (vcavity.sensor.grid; physics.md sections 6 and 9).

The module under test uses atan of a ratio and r^2 = (x^2 + y^2)/(1 + z); the plain
NumPy references here use the textbook forms (cos(pi/2 - a), arctan2 on the disk point)
so that the two implementations share no code.
"""

import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from vcavity.sensor.binning import cell_index, direction_to_cell, hemisphere_to_square, square_to_hemisphere
from vcavity.sensor.grid import EqualAreaSensor, square_to_hemisphere_array

RESOLUTIONS = [1, 2, 57, 100]


# ---------------------------------------------------------------- plain-NumPy references
def reference_square_to_hemisphere(u, v):
    """Shirley-Chiu concentric map + lift z = 1 - r^2 (physics.md section 6)."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u_major = np.abs(u) >= np.abs(v)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(u_major, u, v)
        phi = np.where(u_major, (np.pi / 4) * (v / u), np.pi / 2 - (np.pi / 4) * (u / v))
    phi = np.where(r == 0.0, 0.0, phi)
    disk_x, disk_y = r * np.cos(phi), r * np.sin(phi)
    lift = np.sqrt(2.0 - r * r)
    return np.stack([disk_x * lift, disk_y * lift, 1.0 - r * r], axis=-1)


def reference_hemisphere_to_square(directions):
    """Inverse concentric map with arctan2 on the disk point (x, y)/sqrt(1 + z)."""
    x, y, z = np.asarray(directions, dtype=float).T
    z = np.clip(z, 0.0, 1.0)
    disk_x, disk_y = x / np.sqrt(1.0 + z), y / np.sqrt(1.0 + z)
    r = np.minimum(np.hypot(disk_x, disk_y), 1.0)
    phi = np.arctan2(disk_y, disk_x)  # (-pi, pi]
    q = np.pi / 4
    u = np.empty_like(r)
    v = np.empty_like(r)
    right = np.abs(phi) <= q
    top = (phi > q) & (phi < 3 * q)
    bottom = (phi < -q) & (phi > -3 * q)
    left = ~(right | top | bottom)
    u[right], v[right] = r[right], r[right] * phi[right] / q
    u[top], v[top] = r[top] * (np.pi / 2 - phi[top]) / q, r[top]
    u[bottom], v[bottom] = r[bottom] * (np.pi / 2 + phi[bottom]) / q, -r[bottom]
    phi_left = np.where(phi[left] > 0, phi[left] - np.pi, phi[left] + np.pi)
    u[left], v[left] = -r[left], -r[left] * phi_left / q
    return u, v


def reference_bin(t, resolution):
    return np.clip(np.floor((t + 1.0) / 2.0 * resolution), 0, resolution - 1).astype(np.int64)


def uniform_hemisphere(rng, n):
    """Uniform in solid angle by Archimedes: z uniform on [0, 1], azimuth uniform."""
    z = rng.random(n)
    phi = 2.0 * np.pi * rng.random(n)
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)


def edge_case_directions(resolution, rng):
    """Pole, horizon, exact cell boundaries, near-unit norms, signed zeros."""
    cases = [[0.0, 0.0, 1.0], [-0.0, -0.0, 1.0], [0.0, 0.0, 1.0 + 2e-16], [0.0, 0.0, 0.0]]
    for phi in np.linspace(0.0, 2.0 * np.pi, 17):  # horizon incl. axes and diagonals
        cases.append([np.cos(phi), np.sin(phi), 0.0])
        cases.append([np.cos(phi), np.sin(phi), -1e-17])
    h = np.sqrt(0.5)
    cases += [[h, h, 0.0], [-h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, -0.0]]
    boundaries = -1.0 + 2.0 * np.arange(resolution + 1) / resolution
    along = rng.uniform(-1.0, 1.0, boundaries.size)
    square_points = [(b, a) for b, a in zip(boundaries, along)]
    square_points += [(a, b) for b, a in zip(boundaries, along)]
    square_points += [(b, b) for b in boundaries] + [(b, -b) for b in boundaries]
    for offset in (-1e-11, 1e-11):  # just inside a cell: must bin like the reference
        inner = np.clip(boundaries + offset, -1.0, 1.0)
        square_points += [(b, a) for b, a in zip(inner, along)]
        square_points += [(a, b) for b, a in zip(inner, along[::-1])]
    for u, v in square_points:
        cases.append(reference_square_to_hemisphere(u, v).tolist())
    cases = np.array(cases)
    ulps = np.array([1.0 + 2.0**-52, 1.0 + 3 * 2.0**-52, 1.0 - 2.0**-53, 1.0 - 3 * 2.0**-53])
    near_unit = cases[:, None, :] * ulps[None, :, None]
    return np.concatenate([cases, near_unit.reshape(-1, 3)])


# ---------------------------------------------------------------------- the maps
def test_square_to_hemisphere_matches_reference_is_unit_and_round_trips():
    rng = np.random.default_rng(1)
    uv = rng.uniform(-1.0, 1.0, (20000, 2))
    special = [(0, 0), (1, 1), (-1, 1), (1, -1), (-1, -1), (1, 0), (0, -1), (0.3, 0.3), (-0.3, 0.3), (1e-9, 0)]
    uv = np.concatenate([uv, np.array(special, dtype=float)])
    expected = reference_square_to_hemisphere(uv[:, 0], uv[:, 1])
    mapped = np.array([square_to_hemisphere(u, v) for u, v in uv])
    np.testing.assert_allclose(mapped, expected, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.sum(mapped**2, axis=1), 1.0, rtol=0, atol=1e-14)
    assert np.all(mapped[:, 2] >= 0.0)
    back = np.array([hemisphere_to_square(x, y, z) for x, y, z in mapped])
    np.testing.assert_allclose(back, uv, rtol=0, atol=1e-12)


def test_hemisphere_to_square_matches_arctan2_reference():
    rng = np.random.default_rng(2)
    directions = uniform_hemisphere(rng, 20000)
    ref_u, ref_v = reference_hemisphere_to_square(directions)
    square = np.array([hemisphere_to_square(x, y, z) for x, y, z in directions])
    assert np.all(np.abs(square) <= 1.0)
    np.testing.assert_allclose(square, np.stack([ref_u, ref_v], axis=1), rtol=0, atol=1e-12)
    back = np.array([square_to_hemisphere(u, v) for u, v in square])
    np.testing.assert_allclose(back, directions, rtol=0, atol=1e-12)


def test_numpy_map_agrees_with_the_kernel_map():
    """square_to_hemisphere_array (NumPy) against the jitted map the kernel inlines."""
    rng = np.random.default_rng(4)
    uv = rng.uniform(-1.0, 1.0, (50000, 2))
    edges = np.linspace(-1.0, 1.0, 41)  # ties |u| == |v|, axes, signed zeros, corners
    special = [(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (1e-300, 0.0), (0.0, -1e-300)]
    special += [(a, b) for a in edges for b in (a, -a, 0.0, -0.0, 1.0, -1.0)]
    uv = np.concatenate([uv, np.array(special)])
    mapped = square_to_hemisphere_array(uv[:, 0], uv[:, 1])
    kernel = np.array([square_to_hemisphere(u, v) for u, v in uv])
    assert mapped.shape == (uv.shape[0], 3)
    np.testing.assert_allclose(mapped, kernel, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(square_to_hemisphere_array(0.0, -0.0), [0.0, 0.0, 1.0])
    grid = square_to_hemisphere_array(uv[:6, 0].reshape(2, 3), uv[:6, 1].reshape(2, 3))
    np.testing.assert_array_equal(grid, mapped[:6].reshape(2, 3, 3))  # broadcasting shapes


# ----------------------------------------------------------------------- binning
@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_binning_valid_deterministic_and_matches_reference(resolution):
    rng = np.random.default_rng(3 + resolution)
    sensor = EqualAreaSensor(resolution)
    directions = np.concatenate([uniform_hemisphere(rng, 20000), edge_case_directions(resolution, rng)])
    cells = cell_index(sensor, directions)
    assert cells.dtype == np.int64 and cells.shape == (directions.shape[0],)
    assert np.all((cells >= 0) & (cells < sensor.n_cells))
    np.testing.assert_array_equal(cells, cell_index(sensor, directions))  # deterministic
    scalar = [direction_to_cell(x, y, z, resolution) for x, y, z in directions]
    np.testing.assert_array_equal(cells, scalar)  # array path bins exactly as the kernel
    ref_u, ref_v = reference_hemisphere_to_square(directions)
    ref_ix, ref_iy = reference_bin(ref_u, resolution), reference_bin(ref_v, resolution)
    ix, iy = cells % resolution, cells // resolution
    boundaries = -1.0 + 2.0 * np.arange(resolution + 1) / resolution

    def near_boundary(t):
        return np.min(np.abs(t[:, None] - boundaries[None, :]), axis=1) < 1e-12

    mismatch_x, mismatch_y = ix != ref_ix, iy != ref_iy
    # Only coordinates within 1e-12 of a cell boundary may bin differently, and then
    # only into the neighbouring cell.
    assert not np.any(mismatch_x & ~near_boundary(ref_u))
    assert not np.any(mismatch_y & ~near_boundary(ref_v))
    assert np.all(np.abs(ix - ref_ix) <= 1) and np.all(np.abs(iy - ref_iy) <= 1)


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_binning_of_special_directions(resolution):
    sensor = EqualAreaSensor(resolution)
    middle = resolution // 2
    # the pole maps to (u, v) = (0, 0), i.e. floor(N/2) on both axes
    assert cell_index(sensor, np.array([[0.0, 0.0, 1.0]]))[0] == middle * resolution + middle
    # horizon +x is u = 1, v = 0; -y is u = 0, v = -1; diagonal horizon is a corner
    h = np.sqrt(0.5)
    horizon = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [-h, -h, 0.0], [h, h, 0.0]])
    np.testing.assert_array_equal(
        cell_index(sensor, horizon),
        [middle * resolution + resolution - 1, middle, 0, sensor.n_cells - 1],
    )
    # NaN and a lower-hemisphere direction still give a valid index
    odd = cell_index(sensor, np.array([[np.nan, 0.0, 1.0], [0.3, 0.4, -0.8]]))
    assert np.all((odd >= 0) & (odd < sensor.n_cells))


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_cell_center_round_trip(resolution):
    sensor = EqualAreaSensor(resolution)
    centers = sensor.cell_center
    assert centers.shape == (sensor.n_cells, 3)
    np.testing.assert_allclose(np.linalg.norm(centers, axis=1), 1.0, atol=1e-14)
    np.testing.assert_array_equal(cell_index(sensor, centers), np.arange(sensor.n_cells))


def test_uniform_directions_fill_cells_equally():
    # Chi-square goodness of fit to equal cell probabilities 1/3249; with a fixed seed
    # the test is deterministic, and under a correct partition it would fail for at
    # most a fraction 1e-4 of seeds (p-value threshold).
    sensor = EqualAreaSensor(57)
    rng = np.random.default_rng(20240607)
    counts = np.bincount(cell_index(sensor, uniform_hemisphere(rng, 2_000_000)), minlength=sensor.n_cells)
    assert stats.chisquare(counts).pvalue > 1e-4


# ---------------------------------------------------------------- solid angles
@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_solid_angles_equal_and_sum_to_two_pi(resolution):
    sensor = EqualAreaSensor(resolution)
    omega = sensor.cell_solid_angle
    assert omega.shape == (sensor.n_cells,)
    np.testing.assert_allclose(omega, 2.0 * np.pi / resolution**2, rtol=1e-15)
    assert abs(omega.sum() - 2.0 * np.pi) < 1e-12


def closed_form_projected(u_lower, u_upper, v_lower, v_upper):
    """(pi/2) * integral of (1 - max(u^2, v^2)) by inclusion-exclusion of corner integrals.

    G(p, q) = int_0^p int_0^q max(u^2, v^2) dv du = p^4/2 + p (q^3 - p^3)/3 for p <= q
    (triangle p^4/2 plus strip), extended oddly to signed corners.
    """

    def corner(s, t):
        p, q = np.minimum(abs(s), abs(t)), np.maximum(abs(s), abs(t))
        return np.sign(s) * np.sign(t) * (p**4 / 2 + p * (q**3 - p**3) / 3)

    area = (u_upper - u_lower) * (v_upper - v_lower)
    max_integral = corner(u_upper, v_upper) - corner(u_lower, v_upper) - corner(u_upper, v_lower) + corner(u_lower, v_lower)
    return 0.5 * np.pi * (area - max_integral)


def cell_bounds(cell, resolution):
    ix, iy = cell % resolution, cell // resolution
    w = 2.0 / resolution
    return -1.0 + w * ix, -1.0 + w * (ix + 1), -1.0 + w * iy, -1.0 + w * (iy + 1)


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_projected_solid_angle_exact(resolution):
    sensor = EqualAreaSensor(resolution)
    projected = sensor.cell_projected_solid_angle
    assert projected.shape == (sensor.n_cells,) and np.all(projected > 0)
    # Total: (pi/2) * (4 - 2) = pi (integral of max(u^2, v^2) over [-1,1]^2 is 2).
    assert abs(projected.sum() - np.pi) < 1e-9
    # Independent closed form; the inclusion-exclusion loses ~1e-12 relative to
    # cancellation in small corner cells, hence the tolerance.
    cells = np.arange(sensor.n_cells)
    np.testing.assert_allclose(projected, closed_form_projected(*cell_bounds(cells, resolution)), rtol=1e-10)
    # 8-fold symmetry of the partition: mirror in u, in v, and swap u <-> v.
    grid = projected.reshape(resolution, resolution)  # [iy, ix]
    np.testing.assert_allclose(grid, grid[:, ::-1], rtol=1e-13)
    np.testing.assert_allclose(grid, grid[::-1, :], rtol=1e-13)
    np.testing.assert_allclose(grid, grid.T, rtol=1e-13)


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_projected_solid_angle_against_brute_force_midpoint(resolution):
    sensor = EqualAreaSensor(resolution)
    n = resolution - 1
    cells = np.unique(
        [0, n, n * resolution, sensor.n_cells - 1,  # corners (cos theta -> 0)
         (resolution // 2) * (resolution + 1),  # centre
         (resolution // 3) * (resolution + 1), (resolution // 3 + 1) * n,  # diagonals
         max(0, (n - 1) * resolution + n), resolution // 2]  # next to a corner, edge
    )
    n_sub = 200
    t = (np.arange(n_sub) + 0.5) / n_sub
    for cell in cells:
        u_lower, u_upper, v_lower, v_upper = cell_bounds(cell, resolution)
        u, v = np.meshgrid(u_lower + (u_upper - u_lower) * t, v_lower + (v_upper - v_lower) * t)
        cos_theta = reference_square_to_hemisphere(u.ravel(), v.ravel())[:, 2]
        midpoint = 0.5 * np.pi * (u_upper - u_lower) * (v_upper - v_lower) * cos_theta.mean()
        relative_error = (midpoint - sensor.cell_projected_solid_angle[cell]) / midpoint
        # cos theta = 1 - max(u^2, v^2) is concave, so by Jensen on each sub-square the
        # midpoint rule overestimates.  Leading-order error, sub-square side s: s^2/12
        # per unit area from the curvature, plus |m| s^3/3 per sub-square centred on
        # |u| = |v| = |m| (the kink).  Relative to the cell that is 1/(2 n_sub^2) in a
        # corner cell (cos theta -> 0 at the corner) and 2/n_sub^2 for N = 1, the worst.
        assert -1e-12 < relative_error < 2.5 / n_sub**2


# ------------------------------------------------------------------- class API
def test_sensor_construction_equality_and_repr():
    sensor = EqualAreaSensor()
    assert sensor.resolution == 57 and sensor.n_cells == 3249
    assert EqualAreaSensor.partition == "shirley-chiu-concentric"
    assert sensor == EqualAreaSensor(57) and sensor != EqualAreaSensor(56)
    assert hash(sensor) == hash(EqualAreaSensor(np.int64(57)))
    assert repr(sensor) == "EqualAreaSensor(resolution=57)"
    for bad in (0, -3, 2.5, "57", True, None):
        with pytest.raises(ValueError):
            EqualAreaSensor(bad)


def test_cell_index_shapes():
    sensor = EqualAreaSensor(4)
    single = cell_index(sensor, [0.0, 0.0, 1.0])
    assert single.shape == () and int(single) == 2 * 4 + 2
    batch = np.tile([[0.0, 0.0, 1.0]], (2, 5, 1))
    assert cell_index(sensor, batch).shape == (2, 5)
    with pytest.raises(ValueError):
        cell_index(sensor, np.zeros((4, 2)))


def reference_centre_angles(resolution):
    """theta and phi of each cell centre from the concentric map in closed form.

    ``cos theta = 1 - r^2`` with ``r = max(|u|, |v|)``, so ``theta = 2 arcsin(r / sqrt 2)``;
    the lift keeps the disk azimuth, which is linear in ``v/u`` (or ``u/v``) on each wedge.
    """
    ix, iy = np.meshgrid(np.arange(resolution), np.arange(resolution))  # [iy, ix]
    u = (-1.0 + (2.0 * ix.ravel() + 1.0) / resolution)
    v = (-1.0 + (2.0 * iy.ravel() + 1.0) / resolution)
    theta = 2.0 * np.arcsin(np.maximum(np.abs(u), np.abs(v)) / np.sqrt(2.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = np.select(
            [np.abs(u) >= np.abs(v), v > 0.0],
            [(np.pi / 4) * (v / u) + np.where(u < 0.0, np.pi, 0.0), np.pi / 2 - (np.pi / 4) * (u / v)],
            -np.pi / 2 - (np.pi / 4) * (u / v),
        )
    return theta, np.nan_to_num(phi)


@pytest.mark.parametrize("resolution", [1, 2, 3, 8, 57, 100])
def test_cell_theta_and_phi(resolution):
    sensor = EqualAreaSensor(resolution)
    theta, phi = sensor.cell_theta, sensor.cell_phi
    assert theta.shape == phi.shape == (sensor.n_cells,) and not theta.flags.writeable
    ref_theta, ref_phi = reference_centre_angles(resolution)
    np.testing.assert_allclose(theta, ref_theta, rtol=0, atol=1e-14)
    wrapped = np.angle(np.exp(1j * (phi - ref_phi)))  # phi - ref_phi modulo 2 pi
    np.testing.assert_allclose(wrapped, 0.0, rtol=0, atol=1e-14)
    assert np.all((phi > -np.pi) & (phi <= np.pi))
    assert np.all((theta >= 0.0) & (theta <= 0.5 * np.pi))
    # the angles describe cell_center: (sin t cos p, sin t sin p, cos t)
    rebuilt = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    np.testing.assert_allclose(rebuilt, sensor.cell_center, rtol=0, atol=1e-15)
    if resolution % 2:
        middle = resolution // 2
        pole = middle * resolution + middle
        assert theta[pole] == 0.0 and phi[pole] == 0.0
        minus_x = middle * resolution + np.arange(middle)  # centres on the -x axis
        assert np.all(phi[minus_x] == np.pi)
        assert np.all(phi[middle * resolution + middle + 1 + np.arange(middle)] == 0.0)  # +x axis
        assert np.all(phi[np.arange(middle) * resolution + middle] == -0.5 * np.pi)  # -y axis


def test_cell_bounds_and_validation():
    sensor = EqualAreaSensor(3)
    u_lower, u_upper, v_lower, v_upper = sensor.cell_bounds(np.array([0, 5, 7]))
    np.testing.assert_allclose(u_lower, [-1.0, 1.0 / 3.0, -1.0 / 3.0], atol=1e-15)
    np.testing.assert_allclose(u_upper, [-1.0 / 3.0, 1.0, 1.0 / 3.0], atol=1e-15)
    np.testing.assert_allclose(v_lower, [-1.0, -1.0 / 3.0, 1.0 / 3.0], atol=1e-15)
    np.testing.assert_allclose(v_upper, [-1.0 / 3.0, 1.0 / 3.0, 1.0], atol=1e-15)
    assert all(b.shape == (9,) for b in sensor.cell_bounds())
    for bad in ([-1], [9], [0.5], [[0, 1]]):
        with pytest.raises(ValueError):
            sensor.cell_bounds(np.array(bad))


def test_sensor_geometry_imports_no_numba():
    """Describing cells (what reading a table needs) never imports Numba; binning does."""
    code = (
        "import sys\n"
        "from vcavity.sensor.grid import EqualAreaSensor\n"
        "s = EqualAreaSensor(7)\n"
        "s.cell_center, s.cell_theta, s.cell_phi, s.cell_bounds()\n"
        "s.cell_solid_angle, s.cell_projected_solid_angle\n"
        "print('numba' in sys.modules)\n"
        "from vcavity.sensor.binning import cell_index\n"
        "cell_index(s, [0.0, 0.0, 1.0])\n"
        "print('numba' in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "True"]
