"""Pieces every facet model shares: event outcomes, specular reflection (physics.md sec. 4-5)
and the bracketing tables that decide ``u < F(cos)`` exactly while mostly skipping F."""

import numpy as np

from vcavity._numba.jit import njit

#: Outcomes of a facet event: the path goes on with a new direction, or it ends.
SCATTERED = 0
ABSORBED = 1

#: Bins of a bracketing table over cos in [0, 1] (:func:`reflectance_brackets`).
BRACKET_BINS = 256
# fine samples per bin that check a bin's monotonicity
_BRACKET_FINE = 32


@njit(cache=True, inline="always")
def reflect(dx, dz, cos_in, nx, nz):
    """Mirror reflection of a direction about the facet normal ``(nx, 0, nz)``.

    ``d' = d + 2 cos_in n`` with ``cos_in = -(d.n)``; the groove-axis component of ``d``
    is unchanged (the normal has none), so only ``(dx, dz)`` are returned.
    """
    return dx + 2.0 * cos_in * nx, dz + 2.0 * cos_in * nz


def reflectance_brackets(reflectance_array) -> np.ndarray:
    """Lower and upper bounds of a reflectance F(cos) on each of ``BRACKET_BINS`` cosine bins.

    Parameters
    ----------
    reflectance_array : callable
        ``reflectance_array(cos) -> F`` on a NumPy array of cosines, the same jitted
        code the facet event evaluates (e.g. ``fresnel_dielectric_array`` with its eta).

    Returns
    -------
    numpy.ndarray
        ``(BRACKET_BINS, 2)`` array. The facet event decides ``u < F(cos)`` from the bounds
        of the cosine's bin (:func:`bracketed_below`) and evaluates the exact F only when
        ``u`` falls between them, so every decision is the exact one while most
        evaluations are skipped.

    Notes
    -----
    Fresnel reflectances are monotone in the cosine except near one minimum (Brewster's
    or the pseudo-Brewster angle, at small cosines for large indices). A bin gets the
    bounds of its end points only when F is monotone in the same sense over the bin and
    both its neighbours (checked on 32 interior points each); every other bin gets the
    impossible bounds (-1, 2), which always fall through to the exact F.
    """
    c = np.linspace(0.0, 1.0, BRACKET_BINS * _BRACKET_FINE + 1)
    f = reflectance_array(c)
    steps = np.diff(f).reshape(BRACKET_BINS, _BRACKET_FINE)
    sense = np.where(np.all(steps <= 0.0, axis=1), -1, np.where(np.all(steps >= 0.0, axis=1), 1, 0))
    padded = np.concatenate([[sense[0]], sense, [sense[-1]]])
    trusted = (sense != 0) & (padded[:-2] == sense) & (padded[2:] == sense)
    ends = f[::_BRACKET_FINE]
    brackets = np.empty((BRACKET_BINS, 2))
    brackets[:, 0] = np.minimum(ends[:-1], ends[1:])
    brackets[:, 1] = np.maximum(ends[:-1], ends[1:])
    brackets[~trusted] = (-1.0, 2.0)
    return brackets


@njit(cache=True, inline="always")
def bracketed_below(u, cos_in, data, offset):
    """``(decided, below)``: whether the bracketing table at ``data[offset:]`` decides
    ``u < F(cos_in)`` by itself, and if so the decision (:func:`reflectance_brackets`)."""
    j = int(cos_in * BRACKET_BINS)
    if j >= BRACKET_BINS:
        j = BRACKET_BINS - 1
    elif j < 0:
        j = 0
    if u < data[offset + 2 * j]:
        return True, True
    if u >= data[offset + 2 * j + 1]:
        return True, False
    return False, False
