"""Perfect mirror facet: every facet hit reflects specularly, ``F == 1`` (physics.md
sec. 4, "Limits"; energy is conserved, physics.md sec. 8)."""

from vcavity._jit import njit

MODEL = "mirror"


@njit(cache=True)
def fresnel(cos_theta, *_):
    """Reflectance of a perfect mirror: 1 for every cosine (extra arguments ignored)."""
    return 1.0


@njit(cache=True)
def albedo(*_):
    """Directional albedo of a perfect mirror facet: 1 (arguments ignored)."""
    return 1.0
