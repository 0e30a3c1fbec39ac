"""Perfect mirror facet: every facet hit reflects specularly, ``F = 1`` (physics.md sec. 4,
limits). Nothing is absorbed, so energy is conserved (physics.md sec. 8). It has no
parameters and one compiled variant; its facet event draws no random number.

Implements the facet interface of :mod:`vcavity.facet.registry`.
"""

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet.common import SCATTERED, reflect

NAME = "mirror"
DESCRIPTION = "perfect mirror facets: every hit reflects specularly (F = 1), nothing is absorbed"
PARAMETERS = ()
VARIANTS = ("mirror",)
#: Named parameter sets as a user writes them in ``[material]``, covering every variant: the
#: conformance suite (tests/facet/test_conformance.py) runs every generic check on each.
EXAMPLES = {"typical": {}}


def variant(values) -> int:
    """The only variant."""
    return 0


def prepare(values) -> np.ndarray:
    """No facet data."""
    return np.zeros(0, dtype=np.float64)


def has_specular(values) -> bool:
    """A mirror is all specular lobe."""
    return True


def body_factor(values) -> float:
    """No body: 0."""
    return 0.0


@njit(cache=True)
def reflectance(cos_theta, data):
    """``F = 1`` for every cosine."""
    return 1.0


@njit(cache=True)
def transmittance(cos_theta, data):
    """``T = 0``: nothing enters a mirror."""
    return 0.0


@njit(cache=True, inline="always")
def event(variant, state, dx, dy, dz, cos_in, nx, nz, data):
    """Reflect about ``(nx, 0, nz)``; see :func:`vcavity.facet.interfaced_lambertian.event`."""
    dx, dz = reflect(dx, dz, cos_in, nx, nz)
    return state, SCATTERED, dx, dy, dz
