"""Directions as the simulation and the tables name them (physics.md sec. 1 conventions)."""

import math

import numpy as np


def incident_vector(theta_i: float, phi_i: float) -> np.ndarray:
    """Unit vector toward the light, ``(sin θ cos φ, sin θ sin φ, cos θ)``.

    Parameters
    ----------
    theta_i, phi_i : float
        Polar and azimuthal angles of the incident direction, in radians (physics.md sec. 1).

    Returns
    -------
    numpy.ndarray, shape (3,)
    """
    s = math.sin(theta_i)
    return np.array([s * math.cos(phi_i), s * math.sin(phi_i), math.cos(theta_i)])
