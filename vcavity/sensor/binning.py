"""The sensor's map and binning as the simulation kernel runs them (physics.md sec. 6).

Jitted scalar functions: the Shirley-Chiu concentric map of the square ``[-1, 1]^2`` to
the unit disk lifted to the upper hemisphere (:func:`square_to_hemisphere`), its inverse
(:func:`hemisphere_to_square`) and :func:`direction_to_cell`, the O(1) binning of an exit
direction. The kernel inlines these; :class:`vcavity.sensor.grid.EqualAreaSensor` (plain NumPy)
describes the cells, and :func:`cell_index` bins directions into them with exactly this code.
Cell ``c = iy * N + ix`` covers ``u`` in ``[-1 + 2 ix/N, -1 + 2 (ix+1)/N]`` and ``v`` in
``[-1 + 2 iy/N, -1 + 2 (iy+1)/N]``.
"""

import math

import numpy as np

from vcavity._numba.jit import njit

QUARTER_PI = 0.25 * np.pi
FOUR_OVER_PI = 4.0 / np.pi


@njit(cache=True)
def square_to_hemisphere(u, v):
    """Map a point of the square ``[-1, 1]^2`` to a unit direction with ``z >= 0``.

    Shirley-Chiu concentric square-to-disk map followed by the area-preserving
    lift ``z = 1 - r^2``, ``(x, y) = (d_x, d_y) sqrt(2 - r^2)`` (physics.md
    section 6).  Since ``r = max(|u|, |v|)``, ``z = 1 - max(u^2, v^2)``
    (physics.md section 9).

    Parameters
    ----------
    u, v : float
        Square coordinates in ``[-1, 1]``.

    Returns
    -------
    x, y, z : float
        Unit direction in the upper hemisphere.
    """
    # Branch order keeps every division away from zero (no exceptions in jitted
    # code); ties |u| == |v| take the u-branch, as in hemisphere_to_square.
    if abs(v) > abs(u):
        radius = v  # signed disk radius
        angle = QUARTER_PI * (u / v)  # (π/2 - φ) for the ±y wedge
        disk_x = radius * np.sin(angle)
        disk_y = radius * np.cos(angle)
    elif u != 0.0:
        radius = u
        angle = QUARTER_PI * (v / u)  # disk angle relative to the ±x axis
        disk_x = radius * np.cos(angle)
        disk_y = radius * np.sin(angle)
    else:  # u == v == 0: the pole
        return 0.0, 0.0, 1.0
    radius_sq = radius * radius
    lift = np.sqrt(2.0 - radius_sq)
    return disk_x * lift, disk_y * lift, 1.0 - radius_sq


@njit(cache=True, inline="always")
def _square_radius(x, y, z):
    """``max(|u|, |v|)`` of a direction: ``sqrt(r^2)`` with ``r^2 = (x^2 + y^2) / (1 + z)``
    (equal to ``1 - z`` on the unit sphere, accurate near the pole, physics.md sec. 6), ``z``
    clamped to ``[0, 1]`` and ``r^2`` to at most 1, so slightly non-normalised input (a few
    ulp) and horizon directions are tolerated."""
    if z < 0.0:
        z = 0.0
    elif z > 1.0:
        z = 1.0
    radius_sq = (x * x + y * y) / (1.0 + z)
    if radius_sq > 1.0:
        radius_sq = 1.0
    return math.sqrt(radius_sq)  # math, not np: numba-cuda has no np.sqrt ufunc on scalars


@njit(cache=True)
def hemisphere_to_square(x, y, z):
    """Inverse of :func:`square_to_hemisphere` for upper-hemisphere unit vectors.

    Uses ``r^2 = (x^2 + y^2) / (1 + z)`` (equal to ``1 - z`` on the unit sphere,
    physics.md section 6) which stays accurate near the pole, and the concentric
    inverse with ``atan`` of a ratio in ``[-1, 1]`` instead of ``atan2``.
    ``z`` is clamped to ``[0, 1]`` and ``r^2`` to ``[0, 1]``, so slightly
    non-normalised input (a few ulp) and horizon directions are tolerated.

    Parameters
    ----------
    x, y, z : float
        Direction with ``z >= 0`` (approximately unit length).

    Returns
    -------
    u, v : float
        Square coordinates in ``[-1, 1]``.
    """
    radius = _square_radius(x, y, z)
    abs_x = abs(x)
    abs_y = abs(y)
    # Branch order keeps every division away from zero (no exceptions in jitted
    # code); ties |x| == |y| take the x-branch, as in square_to_hemisphere.
    if abs_y > abs_x:
        v = radius if y > 0.0 else -radius
        u = v * (FOUR_OVER_PI * np.arctan(x / y))  # ratio in [-1, 1]
    elif abs_x > 0.0:
        u = radius if x > 0.0 else -radius
        v = u * (FOUR_OVER_PI * np.arctan(y / x))
    else:  # pole, or a degenerate / NaN vector: centre of the square
        return 0.0, 0.0
    return u, v


@njit(cache=True)
def _square_coordinate_to_bin(t, resolution):
    """Bin of square coordinate ``t ∈ [-1, 1]`` among ``resolution`` equal bins.

    ``floor((t + 1) / 2 * N)`` clamped to ``[0, N - 1]``; the clamping is done on
    the float so that NaN, ``±1`` and out-of-range values all map to a valid bin.
    """
    scaled = (t + 1.0) * 0.5 * resolution
    if not scaled >= 0.0:  # also catches NaN
        return 0
    if scaled >= resolution:
        return resolution - 1
    return int(math.floor(scaled))  # scaled in [0, N): the same int; numba-cuda has no np.floor


# Abramowitz & Stegun 4.4.49: atan(t) = t P(t^2) on [-1, 1] with |error| <= 2e-8 rad
# (1.36e-8 measured on a 2e7-point grid, tests/sensor/test_grid.py).
_ATAN_COEFFS = (1.0, -0.3333314528, 0.1999355085, -0.1420889944, 0.1065626393,
                -0.0752896400, 0.0429096138, -0.0161657367, 0.0028662257)
_ATAN_MAX_ERROR = 2e-8


@njit(cache=True, inline="always")
def _atan_unit_fast(t):
    """Polynomial atan for ``|t| <= 1`` (A&S 4.4.49), error below ``_ATAN_MAX_ERROR``."""
    t2 = t * t
    p = 0.0028662257
    p = p * t2 - 0.0161657367
    p = p * t2 + 0.0429096138
    p = p * t2 - 0.0752896400
    p = p * t2 + 0.1065626393
    p = p * t2 - 0.1420889944
    p = p * t2 + 0.1999355085
    p = p * t2 - 0.3333314528
    p = p * t2 + 1.0
    return t * p


@njit(cache=True, inline="always")
def direction_to_cell(x, y, z, resolution):
    """Sensor cell index ``iy * N + ix`` of an upper-hemisphere direction.

    ``(u, v) = hemisphere_to_square(x, y, z)``, ``ix = floor((u + 1)/2 N)`` and
    ``iy = floor((v + 1)/2 N)``, each clamped to ``[0, N - 1]`` (physics.md
    section 6).  Deterministic; never returns an index outside ``[0, N^2)``.

    This is the simulator's hot path, so the angular coordinate is first binned with
    a polynomial atan (error < 2e-8 rad); only when that lands within a safe margin
    of a bin edge is it recomputed with the exact ``arctan`` of
    :func:`hemisphere_to_square`. The result is therefore *identical* to binning
    ``hemisphere_to_square(x, y, z)`` (tested), at a fraction of the cost.

    Parameters
    ----------
    x, y, z : float
        Direction with ``z >= 0`` (approximately unit length).
    resolution : int
        ``N``, the number of cells along each side of the square.

    Returns
    -------
    int
        Cell index in ``[0, N^2)``.
    """
    radius = _square_radius(x, y, z)
    abs_x = abs(x)
    abs_y = abs(y)
    if abs_y > abs_x:
        v = radius if y > 0.0 else -radius
        ratio = x / y
        u = v * (FOUR_OVER_PI * _atan_unit_fast(ratio))
        angular = u
    elif abs_x > 0.0:
        u = radius if x > 0.0 else -radius
        ratio = y / x
        v = u * (FOUR_OVER_PI * _atan_unit_fast(ratio))
        angular = v
    else:
        half = _square_coordinate_to_bin(0.0, resolution)
        return np.int64(half) * resolution + half
    # error of `angular` in bin units: N/2 * (4/pi) * 2e-8 * |radius| < N * 1.3e-8
    scaled = (angular + 1.0) * 0.5 * resolution
    frac = scaled - math.floor(scaled)  # math.floor: an int, exact for |scaled| <= N (NaN stays NaN)
    margin = resolution * 1e-7
    if frac < margin or frac > 1.0 - margin:
        u, v = hemisphere_to_square(x, y, z)
    ix = _square_coordinate_to_bin(u, resolution)
    iy = _square_coordinate_to_bin(v, resolution)
    return np.int64(iy) * resolution + ix


@njit(cache=True, error_model="numpy")
def bin_block(xs, ys, zs, n, resolution, cells):
    """``cells[j] = direction_to_cell(xs[j], ys[j], zs[j], resolution)`` for ``j < n``.

    The same arithmetic as :func:`direction_to_cell`, written without branches so the
    first loop vectorises (SIMD sqrt, division and the atan polynomial over a block of
    exits); the rare exits within the safety margin of a bin edge are re-binned exactly in
    a second, scalar loop. The result is identical to :func:`direction_to_cell` element
    by element (tested), including for degenerate and NaN input. ``error_model="numpy"``:
    a division by zero (only in lanes whose result is discarded) must not raise.
    """
    fres = np.float64(resolution)
    margin = resolution * 1e-7
    half = _square_coordinate_to_bin(0.0, resolution)
    centre = np.int64(half) * resolution + half
    for j in range(n):
        x = xs[j]
        y = ys[j]
        z = zs[j]
        radius = _square_radius(x, y, z)
        abs_x = abs(x)
        abs_y = abs(y)
        swap = abs_y > abs_x
        num = x if swap else y
        den = y if swap else x
        aden = abs_y if swap else abs_x
        radial = radius if den > 0.0 else -radius
        angular = radial * (FOUR_OVER_PI * _atan_unit_fast(num / den))
        u = angular if swap else radial
        v = radial if swap else angular
        scaled = (angular + 1.0) * 0.5 * fres
        frac = scaled - np.floor(scaled)
        su = (u + 1.0) * 0.5 * fres
        sv = (v + 1.0) * 0.5 * fres
        # _square_coordinate_to_bin without branches: NaN and negative -> 0, >= N - 1 -> N - 1
        su = su if su >= 0.0 else 0.0
        sv = sv if sv >= 0.0 else 0.0
        su = su if su < fres - 1.0 else fres - 1.0
        sv = sv if sv < fres - 1.0 else fres - 1.0
        iu = np.int64(su)
        iv = np.int64(sv)
        cell = iv * resolution + iu
        exact = (frac < margin) | (frac > 1.0 - margin)
        cells[j] = centre if not aden > 0.0 else (-1 - cell if exact else cell)
    for j in range(n):
        if cells[j] < 0:
            uu, vv = hemisphere_to_square(xs[j], ys[j], zs[j])
            cells[j] = (np.int64(_square_coordinate_to_bin(vv, resolution)) * resolution
                        + _square_coordinate_to_bin(uu, resolution))


@njit(cache=True)
def directions_to_cells(directions, resolution):
    """Loop :func:`direction_to_cell` over the rows of an ``(M, 3)`` array."""
    n_directions = directions.shape[0]
    cells = np.empty(n_directions, dtype=np.int64)
    for k in range(n_directions):
        cells[k] = direction_to_cell(
            directions[k, 0], directions[k, 1], directions[k, 2], resolution
        )
    return cells


@njit(cache=True)
def squares_to_hemisphere(u, v):
    """Loop :func:`square_to_hemisphere` over two 1-D arrays -> ``(M, 3)``."""
    n_points = u.shape[0]
    directions = np.empty((n_points, 3))
    for k in range(n_points):
        x, y, z = square_to_hemisphere(u[k], v[k])
        directions[k, 0] = x
        directions[k, 1] = y
        directions[k, 2] = z
    return directions


__all__ = ["direction_to_cell", "directions_to_cells", "hemisphere_to_square",
           "square_to_hemisphere", "squares_to_hemisphere"]


def cell_index(sensor, directions):
    """Cell index of each direction, binned exactly as the simulation kernel does.

    Runs the kernel's jitted binning (:func:`directions_to_cells`; compiled, or loaded
    from Numba's cache, on first use).

    Parameters
    ----------
    sensor : vcavity.sensor.grid.EqualAreaSensor
        The sensor whose cells are meant (a table's ``table.sensor``).
    directions : array_like, shape (..., 3)
        Upper-hemisphere directions (approximately unit length).

    Returns
    -------
    numpy.ndarray of int64, shape (...)
        Cell indices in ``[0, sensor.n_cells)``.
    """
    directions = np.asarray(directions, dtype=np.float64)
    if directions.ndim < 1 or directions.shape[-1] != 3:
        raise ValueError(f"directions must have shape (..., 3), got {directions.shape}")
    flat = np.ascontiguousarray(directions.reshape(-1, 3))
    return directions_to_cells(flat, sensor.resolution).reshape(directions.shape[:-1])
