"""Where the plane of incidence crosses the sensor's cells (plain NumPy, no Numba).

An in-plane slice of a table is a function of the signed angle ``t`` in [-90, 90] deg
along the great circle through the pole and the incident azimuth ``phi_i``:
``t >= 0`` is the direction ``(theta_o = t, phi_o = phi_i + 180 deg)`` (the specular
side: the mirror direction of ``i`` is ``t = theta_i``), ``t < 0`` is
``(theta_o = -t, phi_o = phi_i)`` (back toward the light).

A table only knows cell averages (physics.md sec. 6), so the slice is a step function:
along each stretch of the plane that lies inside one cell it is that cell's value.
:func:`plane_segments` finds the stretches. Where the plane runs exactly along a cell
border (e.g. ``phi_i = 0`` on a sensor of even resolution ``N``, whose middle row border
is ``y = 0``), picking one side would be arbitrary; the directions just either side of
the plane are binned, and a stretch whose two sides fall in different cells is the mean
of both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Perpendicular offset (rad) of the two probes either side of the plane.
SIDE_OFFSET = 1e-9
#: Sampling step (deg) before the cell borders along the plane are refined by bisection.
COARSE_STEP_DEG = 0.05
#: Bisection steps on each border: 0.05 deg / 2**30, far below any plotting need.
BISECTIONS = 30


def hemisphere_to_square(directions):
    """Sensor square coordinates ``(u, v)`` of upper-hemisphere directions, vectorised.

    The inverse of :func:`vcavity.sensor.grid.square_to_hemisphere_array` as physics.md sec. 6
    ("Binning") states it: ``r^2 = (x^2 + y^2)/(1 + z)``; the larger of ``|x|, |y|``
    picks the wedge, the coordinate along it is ``±r`` and the other
    ``±r (4/pi) atan(ratio)``. Written here in NumPy so plotting needs no JIT; ties and
    rounding at cell borders may differ from the kernel's binning, which only moves a
    border of the plot by ~1e-16.

    Parameters
    ----------
    directions : array_like, shape (..., 3)
        Unit directions with ``z >= 0``.

    Returns
    -------
    u, v : numpy.ndarray, shape (...)
        Points of ``[-1, 1]^2``.
    """
    d = np.asarray(directions, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], np.clip(d[..., 2], 0.0, 1.0)
    r = np.sqrt((x * x + y * y) / (1.0 + z))
    x_major = np.abs(x) >= np.abs(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(x_major, y / x, x / y)
    ratio = np.where(np.isfinite(ratio), ratio, 0.0)  # the pole: x = y = 0
    along = np.where(x_major, np.sign(x), np.sign(y)) * r
    across = along * (4.0 / np.pi) * np.arctan(ratio)
    return np.where(x_major, along, across), np.where(x_major, across, along)


def square_to_cell(u, v, resolution: int):
    """Cell index ``iy N + ix`` of square points (physics.md sec. 6), clamped to the grid."""
    n = int(resolution)
    ix = np.clip(np.floor((np.asarray(u) + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)
    iy = np.clip(np.floor((np.asarray(v) + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)
    return iy * n + ix


def plane_directions(t_deg, phi_i: float, side: float = 0.0):
    """Unit directions at signed angles ``t_deg`` along the plane of incidence.

    Parameters
    ----------
    t_deg : array_like
        Signed angle in degrees (module docstring).
    phi_i : float
        Incident azimuth, rad.
    side : float
        Offset (rad) along the plane's normal ``(-sin phi_i, cos phi_i, 0)``.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
    """
    t = np.radians(np.asarray(t_deg, dtype=np.float64))
    # t > 0 points to phi_i + pi: o = (-sin t cos phi_i, -sin t sin phi_i, cos t)
    c, s = np.cos(phi_i), np.sin(phi_i)
    o = np.stack([-np.sin(t) * c - side * s, -np.sin(t) * s + side * c, np.cos(t)], axis=-1)
    return o / np.linalg.norm(o, axis=-1, keepdims=True)


@dataclass(frozen=True)
class PlaneSegments:
    """The stretches of the plane of incidence inside sensor cells.

    Attributes
    ----------
    edges : ndarray (n + 1,)
        Signed angles (deg) bounding the stretches, increasing from -90 to 90.
    cells : ndarray of int64 (n, 2)
        The cells either side of the plane along each stretch (equal unless the plane
        runs along a cell border); the slice's value there is the mean of both.
    """

    edges: np.ndarray
    cells: np.ndarray

    @property
    def centers(self) -> np.ndarray:
        """Mid-angle of each stretch, deg."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


def _pairs(t_deg, phi_i, resolution):
    cells = [square_to_cell(*hemisphere_to_square(plane_directions(t_deg, phi_i, side)), resolution)
             for side in (-SIDE_OFFSET, SIDE_OFFSET)]
    return np.stack(cells, axis=-1)


def plane_segments(resolution: int, phi_i: float) -> PlaneSegments:
    """Cells crossed by the plane of incidence and where it enters and leaves each.

    Samples the plane every :data:`COARSE_STEP_DEG`, then locates each change of cell
    pair by bisection between the two samples around it (module docstring).

    Parameters
    ----------
    resolution : int
        Sensor resolution ``N``.
    phi_i : float
        Incident azimuth, rad.

    Returns
    -------
    PlaneSegments
    """
    n_steps = int(round(180.0 / COARSE_STEP_DEG))
    t = np.linspace(-90.0, 90.0, n_steps + 1)
    pairs = _pairs(t, phi_i, resolution)
    change = np.flatnonzero(np.any(pairs[1:] != pairs[:-1], axis=1))
    lo, hi = t[change].copy(), t[change + 1].copy()
    left = pairs[change]
    for _ in range(BISECTIONS):  # all borders at once
        mid = 0.5 * (lo + hi)
        same = np.all(_pairs(mid, phi_i, resolution) == left, axis=1)
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    edges = np.concatenate([[-90.0], 0.5 * (lo + hi), [90.0]])
    cells = np.concatenate([pairs[:1], pairs[change + 1]])
    return PlaneSegments(edges=edges, cells=cells)
