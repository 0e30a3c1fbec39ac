"""A triangle's mass spread over the sensor's cells, each cell's share exact for a linear
density (physics.md sec. 13): the every-order specular model's push-forward
(:mod:`vcavity.analytic.specular_orders`) carries each quad of its mesh to the sensor as two
triangles whose images are taken affine; each image triangle is clipped against the cells
(Sutherland-Hodgman) and every clipped polygon gets the exact integral of the linear density
over it (area times the density at its centroid).

Coordinates are points of the sensor's square in cell units: cell ``(cx, cy)`` is
``[cx, cx + 1) x [cy, cy + 1)``, its index ``cy * resolution + cx``.
"""

from __future__ import annotations

import math

from vcavity._numba.jit import njit

#: Entries of the work arrays: a triangle clipped by four half-planes has at most 7 corners.
MAX_POLYGON = 12


@njit(cache=True, inline="always")
def cell_of(x, y, resolution):
    """The index of the cell holding point ``(x, y)`` of the sensor's square (cell units),
    clamped to the square."""
    ix = min(max(int(math.floor(x)), 0), resolution - 1)
    iy = min(max(int(math.floor(y)), 0), resolution - 1)
    return iy * resolution + ix


@njit(cache=True, inline="always")
def _clip(px, py, n, qx, qy, axis, bound, keep_above):
    """Sutherland-Hodgman: the part of polygon ``(px, py)[:n]`` on one side of a grid line."""
    m = 0
    for k in range(n):
        ax, ay = px[k], py[k]
        bx, by = px[(k + 1) % n], py[(k + 1) % n]
        ca = ax if axis == 0 else ay
        cb = bx if axis == 0 else by
        a_in = ca >= bound if keep_above else ca <= bound
        b_in = cb >= bound if keep_above else cb <= bound
        if a_in:
            qx[m], qy[m] = ax, ay
            m += 1
        if a_in != b_in:
            f = (bound - ca) / (cb - ca)
            qx[m], qy[m] = ax + f * (bx - ax), ay + f * (by - ay)
            m += 1
    return m


@njit(cache=True)
def splat_triangle(acc, base, x0, y0, x1, y1, x2, y2, m0, m1, m2, mass, resolution, px, py, qx, qy, parts):
    """Add ``mass`` to the cells under the image triangle, each cell's share the integral of
    the linear density with corner values ``m0, m1, m2`` over the triangle's part in it.

    ``px, py, qx, qy`` are work arrays of :data:`MAX_POLYGON` entries; ``parts`` keeps the
    cells' integrals between the two passes (when the triangle's box of cells fits in it;
    otherwise they are computed twice)."""
    lo_x = min(max(int(math.floor(min(x0, x1, x2))), 0), resolution - 1)
    hi_x = min(max(int(math.floor(max(x0, x1, x2))), 0), resolution - 1)
    lo_y = min(max(int(math.floor(min(y0, y1, y2))), 0), resolution - 1)
    hi_y = min(max(int(math.floor(max(y0, y1, y2))), 0), resolution - 1)
    if lo_x == hi_x and lo_y == hi_y:
        acc[base + lo_y * resolution + lo_x] += mass
        return
    area2 = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    total = m0 + m1 + m2
    if abs(area2) < 1e-24 or not total > 0.0:  # degenerate image: the centroid's cell
        acc[base + cell_of((x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, resolution)] += mass
        return
    # two passes: the shares of the clipped parts, then the mass in proportion to them
    # (normalised by their sum, so that a thin triangle's rounding cannot lose mass)
    n_x = hi_x - lo_x + 1
    stored = n_x * (hi_y - lo_y + 1) <= parts.size
    shares = 0.0
    for cy in range(lo_y, hi_y + 1):
        for cx in range(lo_x, hi_x + 1):
            part = _clipped_integral(cx, cy, x0, y0, x1, y1, x2, y2, m0, m1, m2, area2, px, py, qx, qy)
            if stored:
                parts[(cy - lo_y) * n_x + cx - lo_x] = part
            shares += part
    if not shares > 0.0:  # rounding left nothing: the centroid's cell
        acc[base + cell_of((x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, resolution)] += mass
        return
    for cy in range(lo_y, hi_y + 1):
        for cx in range(lo_x, hi_x + 1):
            if stored:
                part = parts[(cy - lo_y) * n_x + cx - lo_x]
            else:
                part = _clipped_integral(cx, cy, x0, y0, x1, y1, x2, y2, m0, m1, m2, area2, px, py, qx, qy)
            if part > 0.0:
                acc[base + cy * resolution + cx] += mass * (part / shares)


@njit(cache=True, inline="always")
def _clipped_integral(cx, cy, x0, y0, x1, y1, x2, y2, m0, m1, m2, area2, px, py, qx, qy):
    """Integral over cell ``(cx, cy)`` of the linear density with corner values ``m0, m1, m2``
    on the triangle (area and centroid of the clipped polygon: exact for a linear density)."""
    px[0], py[0], px[1], py[1], px[2], py[2] = x0, y0, x1, y1, x2, y2
    n = _clip(px, py, 3, qx, qy, 0, float(cx), True)
    n = _clip(qx, qy, n, px, py, 0, float(cx + 1), False)
    n = _clip(px, py, n, qx, qy, 1, float(cy), True)
    n = _clip(qx, qy, n, px, py, 1, float(cy + 1), False)
    if n < 3:
        return 0.0
    a2 = 0.0
    gx = 0.0
    gy = 0.0
    for k in range(n):
        cross = px[k] * py[(k + 1) % n] - px[(k + 1) % n] * py[k]
        a2 += cross
        gx += (px[k] + px[(k + 1) % n]) * cross
        gy += (py[k] + py[(k + 1) % n]) * cross
    if a2 == 0.0:
        return 0.0
    gx /= 3.0 * a2
    gy /= 3.0 * a2
    # barycentric coordinates of the centroid: the linear density there
    l1 = ((gx - x0) * (y2 - y0) - (x2 - x0) * (gy - y0)) / area2
    l2 = ((x1 - x0) * (gy - y0) - (gx - x0) * (y1 - y0)) / area2
    return max(0.5 * abs(a2) * ((1.0 - l1 - l2) * m0 + l1 * m1 + l2 * m2), 0.0)


__all__ = ["MAX_POLYGON", "cell_of", "splat_triangle"]
