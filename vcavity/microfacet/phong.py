"""Isotropic Phong distribution of microfacet normals (W eq. 30-32).

``params`` layout (float64, shape (14,)): ``[exponent]`` (Walter's ``alpha_p``, ``>= 0``)
followed by the 13 parameters of the Student-t distribution it equals (below).

- ``D(m) = (alpha_p + 2)/(2 pi) cos^alpha_p theta_m`` (W eq. 30, physics.md sec. 2).
- Sampling: ``cos theta_m = (1 - u1)^(1/(alpha_p + 2))``, ``phi_m = 2 pi u2``
  (W eq. 31-32 with ``u1 -> 1 - u1``, the same distribution, so that ``u1 = 0``
  gives the normal and ``u1 -> 1`` stays finite).
- In slopes, ``P22(s) = D(m) cos^4 theta_m = (alpha_p + 2)/(2 pi) (1 + |s|^2)^-(alpha_p/2 + 2)``:
  exactly the Student-t distribution (:mod:`vcavity.microfacet.student_t`) with
  ``gamma = alpha_p/2 + 2`` and ``alpha = sqrt(2/(alpha_p + 2))`` (then ``(gamma - 1)
  alpha^2 = 1`` and ``1/(pi alpha^2) = (alpha_p + 2)/(2 pi)``; physics.md sec. 10). So the
  Smith ``Lambda`` is exact (``SMITH = "exact"``): the STD's, and the visible normals are
  sampled as the STD's. (Walter's sec. 5.2 approximates it by the Beckmann ``Lambda`` with
  ``a = sqrt(0.5 alpha_p + 1)/tan theta_v``, whose ``G1`` is off by up to ~24 % at
  ``alpha_p = 2``, 3 % at 20.)
"""

import math

import numpy as np

from vcavity.microfacet import student_t
from vcavity.microfacet.common import normal_sampler
from vcavity.parameters import Number
from vcavity._numba.jit import njit

NAME = "phong"
DESCRIPTION = "D proportional to cos^exponent theta_m, isotropic (W eq. 30)"
PARAMETERS = (Number("exponent", "Phong exponent alpha_p; like Beckmann alpha = sqrt(2/(alpha_p + 2))",
                     lo=0.0, example=20.0),)
SMITH = "exact"  # the Student-t distribution's (see the module docstring)
#: Named parameter sets as a user writes them in ``[material]``: the conformance suite
#: (tests/microfacet/test_conformance.py) runs every generic check on each (isotropic only).
EXAMPLES = {
    "typical": {"exponent": 20.0},
    "smooth": {"exponent": 200.0},
    "rough": {"exponent": 2.0},
    "uniform": {"exponent": 0.0},  # D = 1/pi: normals uniform in projected area
    "very_smooth": {"exponent": 1e5},
}

_TWO_PI = 2.0 * math.pi
_ONE_MINUS_ULP = 1.0 - 2.0**-53  # largest float64 below 1


def params_from(values):
    """Parameter array (module docstring) from the canonical values (validated upstream).

    Parameters
    ----------
    values : mapping
        ``exponent`` (Walter's ``alpha_p >= 0``).

    Returns
    -------
    ndarray, shape (14,)
    """
    e = float(values["exponent"])
    alpha = math.sqrt(2.0 / (e + 2.0))
    equal = student_t.params_from({"alpha_x": alpha, "alpha_y": alpha, "gamma": 0.5 * e + 2.0})
    return np.concatenate((np.array([e]), equal))


def lobe_width(values):
    """Angular roughness scale: the similar Beckmann alpha, ``sqrt(2/(alpha_p + 2))`` (W sec. 5.2)."""
    return math.sqrt(2.0 / (values["exponent"] + 2.0))


@njit(cache=True)
def sample(u1, u2, params):
    """Sample ``m`` with pdf ``D(m)(m.n)`` (W eq. 31-32).

    ``cos^2 theta_m = (1 - u1)^(2/(alpha_p + 2))``, hence
    ``tan theta_m = sqrt(expm1(-2 log1p(-u1)/(alpha_p + 2)))`` without
    cancellation near the normal.

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: the module docstring's (``params[0]`` is the exponent). Returns: Finite ``tan
    theta_m >= 0`` and a unit azimuth pair (``(1, 0)`` when the tangent is 0).
    """
    if u1 >= 1.0:
        u1 = _ONE_MINUS_ULP
    t2 = math.expm1(-2.0 * math.log1p(-u1) / (params[0] + 2.0))
    if t2 <= 0.0:
        return 0.0, 1.0, 0.0
    phi = _TWO_PI * u2
    return math.sqrt(t2), math.cos(phi), math.sin(phi)


#: Unit normal ``(mx, my, mz)`` sampled with pdf ``D(m)(m.n)``: :func:`sample` as a normal.
sample_normal = normal_sampler(sample)


@njit(cache=True, inline="always")
def sample_disk(a, b, s, params):
    """:func:`sample` with ``u1 = 1 - s`` and azimuth ``(a, b)/sqrt(s)`` (no trig; see
    :func:`vcavity.microfacet.beckmann.sample_disk`): ``cos^2 theta_m = s^(2/(alpha_p + 2))``
    (W eq. 31).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: the module docstring's (``params[0]`` is the exponent).
    """
    inv = 1.0 / math.sqrt(s)
    tan2 = math.expm1(-2.0 * math.log(s) / (params[0] + 2.0))
    return math.sqrt(tan2), a * inv, b * inv


@njit(cache=True)
def D(mx, my, mz, params):
    """Phong distribution of normals (W eq. 30).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: the module docstring's (``params[0]`` is the exponent). Returns: ``D(m)`` in
    1/sr; 0 for ``mz <= 0``.
    """
    if mz <= 0.0:
        return 0.0
    e = params[0]
    return (e + 2.0) / _TWO_PI * mz**e


@njit(cache=True)
def pdf(mx, my, mz, params):
    """Sampling pdf ``D(m)(m.n)`` of :func:`sample_normal` (W eq. 24).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: the module docstring's (``params[0]`` is the exponent). Returns: Density per
    steradian.
    """
    if mz <= 0.0:
        return 0.0
    e = params[0]
    return (e + 2.0) / _TWO_PI * mz ** (e + 1.0)


@njit(cache=True)
def smith_lambda(vx, vy, vz, params):
    """Exact Smith ``Lambda(v)`` for Phong: the equal Student-t distribution's (module docstring).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring. Returns:
    ``Lambda >= 0``; 0 for ``vz >= 1``, ``inf`` for ``vz <= 0``.
    """
    return student_t.smith_lambda(vx, vy, vz, params[1:])


@njit(cache=True)
def sample_visible(vx, vy, vz, u1, u2, params):
    """Sample ``m`` with the visible-normal density ``<v, m>+ D(m)`` normalised: the equal
    Student-t distribution's sampler (module docstring, physics.md sec. 14).

    Arguments and results as in the distribution interface
    (:mod:`vcavity.microfacet.registry`); ``params``: see the module docstring.
    """
    return student_t.sample_visible(vx, vy, vz, u1, u2, params[1:])
