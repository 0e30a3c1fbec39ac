"""Equal-solid-angle sensor over the upper hemisphere (physics.md section 6), in NumPy.

The hemisphere is partitioned into ``N x N`` cells: the square ``[-1, 1]^2`` is cut
into ``N x N`` equal squares, mapped to the unit disk by the Shirley-Chiu concentric
map and lifted to the hemisphere by ``z = 1 - r^2``,
``(x, y) = (d_x, d_y) sqrt(2 - r^2)`` (``(d_x, d_y)`` the disk point, ``r`` its
radius).  Both steps preserve area up to a constant, ``dω = (π/2) du dv``
(physics.md section 9, "Projected solid angle of a cell"), so every cell subtends
``2π/N^2`` sr and binning a direction is O(1).

Cell ``c = iy * N + ix`` covers ``u ∈ [-1 + 2 ix/N, -1 + 2 (ix+1)/N]`` and
``v ∈ [-1 + 2 iy/N, -1 + 2 (iy+1)/N]``.

This module describes the cells (bounds, centres and their angles, solid angles,
exact projected solid angles) in plain NumPy and imports no Numba, so reading a table
needs no JIT compilation. Binning directions into cells is the kernel's own jitted code,
:func:`vcavity.sensor.binning.cell_index`, so a direction lands in exactly the cell the
kernel counted it in.
"""

from functools import cached_property

import numpy as np

_QUARTER_PI = 0.25 * np.pi


def square_to_hemisphere_array(u, v):
    """Concentric map of square points to upper-hemisphere unit directions, vectorised.

    The NumPy counterpart of :func:`vcavity.sensor.binning.square_to_hemisphere` (same
    branches, same formulas; results agree to rounding, about 1e-16): the
    Shirley-Chiu concentric map to the disk followed by the lift ``z = 1 - r^2``,
    ``(x, y) = (d_x, d_y) sqrt(2 - r^2)`` (physics.md section 6).

    Parameters
    ----------
    u, v : array_like
        Square coordinates in ``[-1, 1]``; broadcast against each other.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Unit directions with ``z >= 0``; ``(0, 0, 1)`` where ``u = v = 0``.
    """
    u, v = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64))
    v_major = np.abs(v) > np.abs(u)  # ties |u| == |v| take the u-branch, as the kernel does
    radius = np.where(v_major, v, u)  # signed disk radius, max(|u|, |v|) in magnitude
    pole = radius == 0.0  # only at u == v == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(v_major, u / v, v / u)
    angle = _QUARTER_PI * np.where(pole, 0.0, ratio)  # (π/2 - φ) on the ±y wedges
    cos_angle, sin_angle = np.cos(angle), np.sin(angle)
    disk_x = radius * np.where(v_major, sin_angle, cos_angle)
    disk_y = radius * np.where(v_major, cos_angle, sin_angle)
    radius_sq = radius * radius
    lift = np.sqrt(2.0 - radius_sq)
    directions = np.stack([disk_x * lift, disk_y * lift, 1.0 - radius_sq], axis=-1)
    directions[pole] = (0.0, 0.0, 1.0)
    return directions


def _integral_one_minus_v_sq(lower, upper):
    """``∫_lower^upper (1 - v^2) dv`` written to avoid cancellation near ``|v| = 1``."""
    return (upper - lower) * (1.0 - (upper * upper + upper * lower + lower * lower) / 3.0)


def _inner_cos_integral(u, v_lower, v_upper):
    """``∫_{v_lower}^{v_upper} (1 - max(u^2, v^2)) dv`` exactly (vectorised over arrays).

    Where ``|v| < |u|`` the integrand is ``1 - u^2``, elsewhere ``1 - v^2``
    (physics.md section 9).
    """
    abs_u = np.abs(u)
    flat_lower = np.maximum(v_lower, -abs_u)  # [flat_lower, flat_upper] = {|v| < |u|}
    flat_upper = np.minimum(v_upper, abs_u)
    has_flat = flat_upper > flat_lower
    flat_part = np.where(
        has_flat, (1.0 - abs_u) * (1.0 + abs_u) * (flat_upper - flat_lower), 0.0
    )
    below_upper = np.where(has_flat, flat_lower, v_upper)  # |v| >= |u| below the flat part
    above_lower = np.where(has_flat, flat_upper, v_upper)  # ... and above it
    return (
        flat_part
        + _integral_one_minus_v_sq(v_lower, below_upper)
        + _integral_one_minus_v_sq(above_lower, v_upper)
    )


def _projected_integral_over_rectangles(u_lower, u_upper, v_lower, v_upper):
    """``∫∫ (1 - max(u^2, v^2)) du dv`` over rectangles, exactly (physics.md section 9).

    For fixed ``u`` the ``v``-integral is a polynomial of degree <= 3 in ``u`` on
    each interval between the breakpoints ``u ∈ {±v_lower, ±v_upper, 0}``; two-point
    Gauss-Legendre on each such piece is therefore exact.
    """
    u_lower = np.asarray(u_lower, dtype=np.float64)
    u_upper = np.asarray(u_upper, dtype=np.float64)
    candidates = np.stack(
        [u_lower, u_upper, v_lower, -v_lower, v_upper, -v_upper, np.zeros_like(u_lower)],
        axis=-1,
    )
    breakpoints = np.sort(np.clip(candidates, u_lower[:, None], u_upper[:, None]), axis=-1)
    piece_lower = breakpoints[:, :-1]
    piece_upper = breakpoints[:, 1:]
    half_width = 0.5 * (piece_upper - piece_lower)
    midpoint = 0.5 * (piece_upper + piece_lower)
    offset = half_width / np.sqrt(3.0)  # 2-point Gauss-Legendre: nodes ±1/√3, weights 1
    v_lo = np.asarray(v_lower, dtype=np.float64)[:, None]
    v_hi = np.asarray(v_upper, dtype=np.float64)[:, None]
    piece_integrals = half_width * (
        _inner_cos_integral(midpoint - offset, v_lo, v_hi)
        + _inner_cos_integral(midpoint + offset, v_lo, v_hi)
    )
    return piece_integrals.sum(axis=-1)


class EqualAreaSensor:
    """Equal-solid-angle partition of the upper hemisphere (physics.md section 6).

    Parameters
    ----------
    resolution : int, optional
        ``N``; the sensor has ``N * N`` cells of ``2π/N^2`` sr each.  Default 57
        (3249 cells).

    Raises
    ------
    ValueError
        If ``resolution`` is not an integer >= 1.
    """

    partition = "shirley-chiu-concentric"

    def __init__(self, resolution: int = 57):
        if isinstance(resolution, (bool, np.bool_)) or not isinstance(
            resolution, (int, np.integer)
        ):
            raise ValueError(f"resolution must be an int >= 1, got {resolution!r}")
        if resolution < 1:
            raise ValueError(f"resolution must be an int >= 1, got {resolution!r}")
        self.resolution = int(resolution)
        self.n_cells = self.resolution * self.resolution

    def __repr__(self):
        return f"EqualAreaSensor(resolution={self.resolution})"

    def __eq__(self, other):
        if not isinstance(other, EqualAreaSensor):
            return NotImplemented
        return self.partition == other.partition and self.resolution == other.resolution

    def __hash__(self):
        return hash((self.partition, self.resolution))

    def cell_bounds(self, cells=None):
        """Square-coordinate bounds of cells.

        Parameters
        ----------
        cells : array_like of int, optional
            1-D array of cell indices in ``[0, n_cells)``; default all cells.

        Returns
        -------
        u_lower, u_upper, v_lower, v_upper : numpy.ndarray
            Each of the shape of ``cells``: cell ``c`` is the square
            ``[u_lower, u_upper] x [v_lower, v_upper]``.

        Raises
        ------
        ValueError
            If ``cells`` is not a 1-D integer array of valid indices.
        """
        cells = self._check_cells(cells)
        width = 2.0 / self.resolution
        ix = cells % self.resolution
        iy = cells // self.resolution
        return -1.0 + width * ix, -1.0 + width * (ix + 1), -1.0 + width * iy, -1.0 + width * (iy + 1)

    def _check_cells(self, cells):
        if cells is None:
            return np.arange(self.n_cells, dtype=np.int64)
        cells = np.asarray(cells)
        if cells.ndim != 1 or not np.issubdtype(cells.dtype, np.integer):
            raise ValueError("cells must be a 1-D array of integer cell indices")
        if cells.size and (cells.min() < 0 or cells.max() >= self.n_cells):
            raise ValueError(f"cell indices must lie in [0, {self.n_cells})")
        return cells.astype(np.int64)

    @cached_property
    def cell_center(self):
        """``(n_cells, 3)`` unit directions: the centre of each square cell, mapped.

        The square centre ``(2 ix + 1 - N) / N`` has one rounding, so centres are exactly
        symmetric and, for odd ``N``, the middle cell's centre is exactly the pole.
        """
        cells = np.arange(self.n_cells)
        centre_u = (2 * (cells % self.resolution) + 1 - self.resolution) / self.resolution
        centre_v = (2 * (cells // self.resolution) + 1 - self.resolution) / self.resolution
        centers = square_to_hemisphere_array(centre_u, centre_v)
        centers.flags.writeable = False
        return centers

    @cached_property
    def cell_theta(self):
        """``(n_cells,)`` polar angle of each cell centre from ``+z``, rad, in ``[0, π/2]``."""
        x, y, z = self.cell_center.T
        theta = np.arctan2(np.hypot(x, y), z)  # accurate at the pole and at the horizon
        theta.flags.writeable = False
        return theta

    @cached_property
    def cell_phi(self):
        """``(n_cells,)`` azimuth of each cell centre from ``+x`` toward ``+y``, rad.

        In ``(-π, π]`` (``arctan2``; a centre on the ``-x`` axis has ``π``, never ``-π``);
        0 for the cell centred on the pole.
        """
        x, y, _ = self.cell_center.T
        phi = np.arctan2(y + 0.0, x)  # + 0.0 turns y = -0.0 into +0.0: -x axis -> +π
        phi[(x == 0.0) & (y == 0.0)] = 0.0
        phi.flags.writeable = False
        return phi

    @cached_property
    def cell_solid_angle(self):
        """``(n_cells,)`` solid angle of each cell, all ``2π/N^2`` sr."""
        solid_angle = np.full(self.n_cells, 2.0 * np.pi / self.n_cells)
        solid_angle.flags.writeable = False
        return solid_angle

    @cached_property
    def cell_projected_solid_angle(self):
        """``(n_cells,)`` projected solid angle ``Ω⊥_c = ∫_c cos θ dω``, exact.

        ``Ω⊥_c = (π/2) ∫∫_cell (1 - max(u^2, v^2)) du dv`` (physics.md section 9),
        integrated exactly (piecewise polynomial).  Sums to ``π``.
        """
        projected = 0.5 * np.pi * _projected_integral_over_rectangles(*self.cell_bounds())
        projected.flags.writeable = False
        return projected
