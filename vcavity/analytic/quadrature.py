"""Sub-cell quadrature over the sensor's cells in solid angle (physics.md sections 6, 9).

A table stores cell averages ``(1/Ω⊥_c) ∫_c f cos θ_o dω_o``; a model is compared with
them by integrating it over each cell with :func:`subcell_quadrature` (used by
:mod:`vcavity.analytic.cells`), never by sampling it at the cell centre.
"""

from __future__ import annotations

import numpy as np

from vcavity.sensor.grid import EqualAreaSensor, square_to_hemisphere_array

# Resolution constants the cell models share (cells.py, peak_cells.py, specular_peak.py):
# here, in the module all three build on, so none of them imports another for a number.
#: Fewest and most sub-points per cell side for the specular term (cells.specular_subpoints).
MIN_SPECULAR_SUB = 16
MAX_SPECULAR_SUB = 48
#: A ray advances by at most this many sensor cell widths (in ``|Δo|``) per scan step, so
#: that it crosses each cell edge once per step and every crossing is bracketed.
STEP_CELLS = 0.4
#: Longest scan step in tau.
MAX_STEP = 1.0 / 32.0


def subcell_quadrature(sensor: EqualAreaSensor, n_sub, cells=None):
    """Gauss-Legendre quadrature over sensor cells in solid angle.

    Tensor-product ``n_sub x n_sub`` Gauss-Legendre nodes in ``(u, v)`` on each
    cell, mapped to the hemisphere; weights include ``dω = (π/2) du dv``
    (physics.md section 9), so they sum to the cell's solid angle.  Use it to
    average a model over a cell the way the sensor does (physics.md section 6).

    The concentric map has a kink along the diagonals ``|u| = |v|``; on the
    uniform grid these are the diagonals of the cells with ``ix == iy`` or
    ``ix + iy == N - 1``.  For ``n_sub >= 4`` such cells are split along both of
    their diagonals into four triangles, each integrated with a collapsed
    (Duffy) Gauss-Legendre rule, so the kink lies on piece boundaries and these
    cells converge as fast as the others (``cos θ`` is integrated exactly).
    With even ``n_sub`` each triangle has ``(n_sub/2)^2`` nodes; with odd
    ``n_sub >= 5`` each has ``(n_sub-1)/2 x (n_sub+1)/2`` nodes and the
    remaining node sits at the cell centre with weight 0.

    Parameters
    ----------
    sensor : EqualAreaSensor
        The sensor whose cells are integrated over.
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

    Raises
    ------
    ValueError
        If ``n_sub`` is not an int >= 1 or ``cells`` holds invalid cell indices.
    """
    if isinstance(n_sub, (bool, np.bool_)) or not isinstance(n_sub, (int, np.integer)):
        raise ValueError(f"n_sub must be an int >= 1, got {n_sub!r}")
    if n_sub < 1:
        raise ValueError(f"n_sub must be an int >= 1, got {n_sub!r}")
    n_sub = int(n_sub)
    u_lower, u_upper, v_lower, v_upper = sensor.cell_bounds(cells)  # validates cells
    cells = np.arange(sensor.n_cells) if cells is None else np.asarray(cells, dtype=np.int64)
    nodes, weights = np.polynomial.legendre.leggauss(n_sub)
    half_width = 1.0 / sensor.resolution  # half of the cell side 2/N
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
        ix = cells % sensor.resolution
        iy = cells // sensor.resolution
        crossed = (ix == iy) | (ix + iy == sensor.resolution - 1)
        if np.any(crossed):
            du, dv, w = _four_triangle_rule(n_sub)  # offsets in units of half_width
            u_grid[crossed] = 0.5 * (u_lower + u_upper)[crossed, None] + half_width * du
            v_grid[crossed] = 0.5 * (v_lower + v_upper)[crossed, None] + half_width * dv
            square_weights[crossed] = half_width * half_width * w
    directions = square_to_hemisphere_array(u_grid, v_grid)  # (C, n_sub * n_sub, 3)
    return directions, 0.5 * np.pi * square_weights


def radius_split_quadrature(sensor: EqualAreaSensor, n_sub: int, cells, radius: float):
    """Gauss-Legendre rule on off-diagonal cells split at the square radius ``radius``.

    A cell off the diagonals ``|u| = |v|`` has ``max(|u|, |v|)`` equal to one of its
    coordinates throughout (``|u|`` where ``|u| > |v|``), so the circle
    ``z = 1 - radius^2`` (physics.md sec. 9) is a straight line through it: the cell is
    cut there into two rectangles, each with an ``n_sub x n_sub`` rule, and an integrand
    with a kink on that circle (the specular term at ``z = cos θ_i``, where
    ``G1_V(o) = G1_V(i)``, IL eq. 14) converges as fast as a smooth one. Cells the circle
    does not cross get the same rule with the cut at their edge (one rectangle of zero
    width).

    Parameters
    ----------
    sensor : EqualAreaSensor
    n_sub : int
        Nodes per side of each rectangle.
    cells : array_like of int
        Cells off the diagonals (``ix != iy`` and ``ix + iy != N - 1``).
    radius : float
        Square radius of the cut, in [0, 1].

    Returns
    -------
    directions : ndarray (C, 2 n_sub^2, 3)
    solid_angle_weights : ndarray (C, 2 n_sub^2)
        Weights in sr; each row sums to ``2π/N^2``.
    """
    cells = np.asarray(cells, dtype=np.int64)
    n = sensor.resolution
    u_lower, u_upper, v_lower, v_upper = sensor.cell_bounds(cells)
    ix, iy = cells % n, cells // n
    if np.any((ix == iy) | (ix + iy == n - 1)):
        raise ValueError("radius_split_quadrature: cells on a diagonal are not split")
    u_centre, v_centre = 0.5 * (u_lower + u_upper), 0.5 * (v_lower + v_upper)
    across_u = np.abs(u_centre) > np.abs(v_centre)  # the cell's radius is |u|
    nodes, weights = np.polynomial.legendre.leggauss(int(n_sub))
    radial_centre = np.where(across_u, u_centre, v_centre)
    sign = np.sign(radial_centre)
    r_lower = np.abs(radial_centre) - 1.0 / n
    r_upper = r_lower + 2.0 / n
    cut = np.clip(radius, r_lower, r_upper)
    along_centre = np.where(across_u, v_centre, u_centre)
    along = along_centre[:, None] + nodes[None, :] / n  # (C, n)
    pieces_r, pieces_w = [], []
    for lo, hi in ((r_lower, cut), (cut, r_upper)):
        half = 0.5 * (hi - lo)
        pieces_r.append(0.5 * (hi + lo)[:, None] + half[:, None] * nodes[None, :])
        pieces_w.append(half[:, None] * weights[None, :])
    r_nodes = np.concatenate(pieces_r, axis=1)  # (C, 2n)
    r_weights = np.concatenate(pieces_w, axis=1)
    radial = sign[:, None, None] * r_nodes[:, :, None] * np.ones((1, 1, n_sub))
    along = np.broadcast_to(along[:, None, :], radial.shape)
    u = np.where(across_u[:, None, None], radial, along).reshape(cells.size, -1)
    v = np.where(across_u[:, None, None], along, radial).reshape(cells.size, -1)
    w2 = (r_weights[:, :, None] * (weights / n)[None, None, :]).reshape(cells.size, -1)
    return square_to_hemisphere_array(u, v), 0.5 * np.pi * w2


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


__all__ = ["subcell_quadrature", "radius_split_quadrature"]
