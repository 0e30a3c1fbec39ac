"""Facet-frame directions shared by the facet tests (not a test module)."""

import math


def incoming(cos_in, tilt=0.3, psi=0.8):
    """A direction of travel d with -(d.n) = cos_in onto the facet normal n = (sin tilt, 0, cos tilt)."""
    nx, nz = math.sin(tilt), math.cos(tilt)
    s = math.sqrt(1.0 - cos_in * cos_in)
    d = (-cos_in * nx + s * math.cos(psi) * nz, s * math.sin(psi), -cos_in * nz - s * math.cos(psi) * nx)
    return d, nx, nz
