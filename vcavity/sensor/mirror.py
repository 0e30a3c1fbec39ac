"""The sensor grid's mirror lines: which planes of incidence fold a table, and each cell's mirror.

The BRDF of an isotropic material is symmetric about every plane of incidence, that of an
anisotropic one (axes along x and y) about the planes phi_i = 0 and 90 deg; the concentric
sensor grid is symmetric under the reflections of the square, about the lines at multiples
of 45 deg (physics.md sec. 6). Where both hold, a cell and its mirror cell are one region
of twice the area, which the estimators fold (:mod:`vcavity.estimators.counts`). Plain
NumPy, no Numba.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.sensor.grid import EqualAreaSensor


def grid_mirror_planes(isotropic: bool) -> float:
    """Spacing in degrees of the azimuths phi_i whose plane of incidence is a mirror
    plane of both the BRDF and the sensor grid.

    The concentric sensor grid is symmetric under the reflections of the square (lines at
    multiples of 45 deg, physics.md sec. 6); an isotropic BRDF is symmetric about every
    plane of incidence, an anisotropic one (axes along x and y) only about the planes
    phi_i = 0 and 90 deg (mod 180).
    """
    return 45.0 if isotropic else 90.0


def has_mirror_symmetry(phi_i_deg: float, isotropic: bool) -> bool:
    """Whether the table of incident azimuth ``phi_i_deg`` may be folded (see module doc)."""
    step = grid_mirror_planes(isotropic)
    return math.isfinite(phi_i_deg) and math.remainder(float(phi_i_deg), step) == 0.0


def mirror_cells(sensor: EqualAreaSensor, phi_i_deg: float) -> np.ndarray:
    """The mirror cell of every cell about the plane of incidence at azimuth ``phi_i_deg``.

    Parameters
    ----------
    sensor : EqualAreaSensor
    phi_i_deg : float
        A multiple of 45 degrees (the grid's mirror lines).

    Returns
    -------
    ndarray of int64 (n_cells,)
        ``mirror[c]`` is the cell whose region is the reflection of cell ``c``; an
        involution, ``mirror[c] == c`` for cells the plane cuts in half.

    Raises
    ------
    ValueError
        If ``phi_i_deg`` is not a multiple of 45 degrees.
    """
    steps = math.remainder(float(phi_i_deg), 180.0) / 45.0  # the line at phi and phi + 180
    if not (math.isfinite(steps) and steps == round(steps)):
        raise ValueError(f"phi_i_deg = {phi_i_deg!r}: the sensor grid has mirror lines only at "
                         "multiples of 45 degrees")
    n = sensor.resolution
    iy, ix = np.divmod(np.arange(n * n, dtype=np.int64), n)
    last = n - 1
    # In the square (u, v) the mirror line of azimuth phi is the line at angle phi
    # (the concentric map keeps the lines at multiples of 45 deg): reflect the indices.
    reflected = {0: (ix, last - iy),           # about phi = 0: v -> -v
                 1: (iy, ix),                  # about phi = 45: u <-> v
                 2: (last - ix, iy),           # about phi = 90: u -> -u
                 -1: (last - iy, last - ix),   # about phi = 135 (= -45): (u, v) -> (-v, -u)
                 -2: (last - ix, iy)}[int(round(steps))]
    return reflected[1] * n + reflected[0]


__all__ = ["grid_mirror_planes", "has_mirror_symmetry", "mirror_cells"]
