"""Pieces every facet model shares: event outcomes and specular reflection (physics.md sec. 4-5)."""

from vcavity._numba.jit import njit

#: Outcomes of a facet event: the path goes on with a new direction, or it ends.
SCATTERED = 0
ABSORBED = 1


@njit(cache=True, inline="always")
def reflect(dx, dz, cos_in, nx, nz):
    """Mirror reflection of a direction about the facet normal ``(nx, 0, nz)``.

    ``d' = d + 2 cos_in n`` with ``cos_in = -(d.n)``; the groove-axis component of ``d``
    is unchanged (the normal has none), so only ``(dx, dz)`` are returned.
    """
    return dx + 2.0 * cos_in * nx, dz + 2.0 * cos_in * nz
