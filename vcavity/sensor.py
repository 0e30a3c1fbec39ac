"""Equal-solid-angle sensor over the upper hemisphere (physics.md section 6).

The hemisphere is partitioned into ``N x N`` cells: the square ``[-1, 1]^2`` is cut
into ``N x N`` equal squares, mapped to the unit disk by the Shirley-Chiu concentric
map and lifted to the hemisphere by ``z = 1 - r^2``,
``(x, y) = (d_x, d_y) sqrt(2 - r^2)`` (``(d_x, d_y)`` the disk point, ``r`` its
radius).  Both steps preserve area up to a constant, ``dω = (π/2) du dv``
(physics.md section 9, "Projected solid angle of a cell"), so every cell subtends
``2π/N^2`` sr and binning a direction is O(1).

Cell ``c = iy * N + ix`` covers ``u ∈ [-1 + 2 ix/N, -1 + 2 (ix+1)/N]`` and
``v ∈ [-1 + 2 iy/N, -1 + 2 (iy+1)/N]``.

The jitted scalar functions (:func:`square_to_hemisphere`,
:func:`hemisphere_to_square`, :func:`direction_to_cell`) are meant to be called from
the simulation kernels; :class:`EqualAreaSensor` bins with exactly the same code.
"""

from functools import cached_property

import numpy as np


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

    def _cell_bounds(self, cells):
        """Square-coordinate bounds ``(u_lower, u_upper, v_lower, v_upper)`` of cells."""
        cells = np.asarray(cells, dtype=np.int64)
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

    def cell_index(self, directions):
        """Cell index of each direction, binned exactly as the simulation kernel does.

        Parameters
        ----------
        directions : array_like, shape (..., 3)
            Upper-hemisphere directions (approximately unit length).

        Returns
        -------
        numpy.ndarray of int64, shape (...)
            Cell indices in ``[0, n_cells)``.
        """
        directions = np.asarray(directions, dtype=np.float64)
        if directions.ndim < 1 or directions.shape[-1] != 3:
            raise ValueError(f"directions must have shape (..., 3), got {directions.shape}")
        flat = np.ascontiguousarray(directions.reshape(-1, 3))
        from vcavity.binning import directions_to_cells

        return directions_to_cells(flat, self.resolution).reshape(directions.shape[:-1])

    @cached_property
    def cell_center(self):
        """``(n_cells, 3)`` directions: the centre of each square cell, mapped."""
        u_lower, u_upper, v_lower, v_upper = self._cell_bounds(np.arange(self.n_cells))
        from vcavity.binning import squares_to_hemisphere

        centers = squares_to_hemisphere(0.5 * (u_lower + u_upper), 0.5 * (v_lower + v_upper))
        centers.flags.writeable = False
        return centers

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
        bounds = self._cell_bounds(np.arange(self.n_cells))
        projected = 0.5 * np.pi * _projected_integral_over_rectangles(*bounds)
        projected.flags.writeable = False
        return projected

    def subcell_quadrature(self, n_sub, cells=None):
        """Gauss-Legendre quadrature over sensor cells in solid angle.

        Tensor-product ``n_sub x n_sub`` Gauss-Legendre nodes in ``(u, v)`` on each
        cell, mapped to the hemisphere; weights include ``dω = (π/2) du dv``
        (physics.md section 9), so they sum to the cell's solid angle.  Use it to
        average a model over a cell the way the sensor does (physics.md section 6).

        The concentric map has a kink along the diagonals ``|u| = |v|``; on the
        uniform grid these are the diagonals of the cells with ``ix == iy`` or
        ``ix + iy == N - 1``.  For ``n_sub >= 2`` such cells are split along both of
        their diagonals into four triangles, each integrated with a collapsed
        (Duffy) Gauss-Legendre rule, so the kink lies on piece boundaries and these
        cells converge as fast as the others (``cos θ`` is integrated exactly) when
        ``n_sub >= 4``.  With even ``n_sub`` each triangle has ``(n_sub/2)^2`` nodes;
        with odd ``n_sub >= 5`` each has ``(n_sub-1)/2 x (n_sub+1)/2`` nodes and the
        remaining node sits at the cell centre with weight 0.

        Parameters
        ----------
        n_sub : int
            Nodes per cell along each of ``u`` and ``v`` (>= 1).
        cells : array_like of int, optional
            Cell indices to build the quadrature for; default all cells.

        Returns
        -------
        directions : numpy.ndarray, shape (C, n_sub * n_sub, 3)
            Quadrature directions per cell.
        solid_angle_weights : numpy.ndarray, shape (C, n_sub * n_sub)
            Weights in sr; each row sums to ``2π/N^2``.
        """
        if isinstance(n_sub, (bool, np.bool_)) or not isinstance(n_sub, (int, np.integer)):
            raise ValueError(f"n_sub must be an int >= 1, got {n_sub!r}")
        if n_sub < 1:
            raise ValueError(f"n_sub must be an int >= 1, got {n_sub!r}")
        n_sub = int(n_sub)
        cells = self._check_cells(cells)
        nodes, weights = np.polynomial.legendre.leggauss(n_sub)
        u_lower, u_upper, v_lower, v_upper = self._cell_bounds(cells)
        half_width = 1.0 / self.resolution  # half of the cell side 2/N
        u_nodes = 0.5 * (u_lower + u_upper)[:, None] + half_width * nodes[None, :]
        v_nodes = 0.5 * (v_lower + v_upper)[:, None] + half_width * nodes[None, :]
        # node k = j * n_sub + i  <->  (u_i, v_j)
        u_grid = np.ascontiguousarray(
            np.broadcast_to(u_nodes[:, None, :], (cells.size, n_sub, n_sub))).reshape(cells.size, -1)
        v_grid = np.ascontiguousarray(
            np.broadcast_to(v_nodes[:, :, None], (cells.size, n_sub, n_sub))).reshape(cells.size, -1)
        weight_2d = (weights[:, None] * weights[None, :]).reshape(-1)  # [j, i] order
        square_weights = np.broadcast_to(
            half_width * half_width * weight_2d, (cells.size, n_sub * n_sub)).copy()
        if n_sub >= 4:  # below 4 a one-node radial rule is worse than the plain one
            ix = cells % self.resolution
            iy = cells // self.resolution
            crossed = (ix == iy) | (ix + iy == self.resolution - 1)
            if np.any(crossed):
                du, dv, w = _four_triangle_rule(n_sub)  # offsets in units of half_width
                u_grid[crossed] = 0.5 * (u_lower + u_upper)[crossed, None] + half_width * du
                v_grid[crossed] = 0.5 * (v_lower + v_upper)[crossed, None] + half_width * dv
                square_weights[crossed] = half_width * half_width * w
        from vcavity.binning import squares_to_hemisphere

        directions = squares_to_hemisphere(u_grid.reshape(-1), v_grid.reshape(-1)).reshape(
            cells.size, n_sub * n_sub, 3)
        return directions, 0.5 * np.pi * square_weights


def _four_triangle_rule(n_sub):
    """Quadrature on the square ``[-1, 1]^2`` split by both diagonals into 4 triangles.

    Triangle (C = 0, E0, E1): collapsed (Duffy) Gauss-Legendre rule
    ``P = s (E0 + t (E1 - E0))``, Jacobian ``s |det(E0, E1 - E0)|``, ``s, t`` in
    ``[0, 1]``.  Returns ``n_sub^2`` offsets ``(du, dv)`` and weights in ``du dv``
    (sum 4); for odd ``n_sub`` the last node is the centre with weight 0.
    """
    n_s = n_sub // 2
    n_t = n_sub - n_s  # == n_s for even n_sub, n_s + 1 for odd
    s_nodes, s_weights = np.polynomial.legendre.leggauss(n_s)
    t_nodes, t_weights = np.polynomial.legendre.leggauss(n_t)
    s_nodes = 0.5 * (s_nodes + 1.0)
    s_weights = 0.5 * s_weights
    t_nodes = 0.5 * (t_nodes + 1.0)
    t_weights = 0.5 * t_weights
    corners = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]])
    du, dv, w = [], [], []
    for k in range(4):
        e0 = corners[k]
        e1 = corners[(k + 1) % 4]
        edge = e1 - e0
        jacobian = abs(e0[0] * edge[1] - e0[1] * edge[0])  # = 2
        s = s_nodes[:, None]
        t = t_nodes[None, :]
        du.append((s * (e0[0] + t * edge[0])).ravel())
        dv.append((s * (e0[1] + t * edge[1])).ravel())
        w.append((jacobian * s * s_weights[:, None] * t_weights[None, :]).ravel())
    du, dv, w = np.concatenate(du), np.concatenate(dv), np.concatenate(w)
    padding = n_sub * n_sub - du.size  # 0 (even n_sub) or 1 (odd)
    return (np.concatenate([du, np.zeros(padding)]), np.concatenate([dv, np.zeros(padding)]),
            np.concatenate([w, np.zeros(padding)]))
