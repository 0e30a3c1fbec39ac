"""Conductor (metal) facet: a flat surface of complex relative index ``eta + i k``
(physics.md sec. 4, conductor facets).

One facet event with incoming cosine ``c`` to the facet normal: with probability
``F(c)`` (:func:`~vcavity.facet.fresnel_conductor.fresnel_conductor`, the exact
unpolarised reflectance of a conductor) the light is reflected specularly, otherwise it is
absorbed: nothing enters a metal and comes back. Each event draws exactly one uniform;
the decision ``u < F(c)`` is taken from a bracketing table of F over cosine bins
(:func:`vcavity.facet.common.reflectance_brackets`), evaluating F only when ``u`` falls
between a bin's bounds, so every decision is the exact one.

``k = 0`` with ``eta > 1`` is the specular dielectric of the interfaced Lambertian facet
with ``kd = 0``; the perfect mirror (``F = 1``) is its own facet model, ``mirror``.

The defaults are gold at 548.6 nm (photon energy 2.26 eV): ``eta = 0.43``, ``k = 2.455``,
from the table of Johnson and Christy (J&C, Phys. Rev. B 6, 4370, 1972); they apply only
together: giving ``eta`` without ``k`` (or ``k`` without ``eta``) is refused.

The facet interface (see :mod:`vcavity.facet.registry`) is implemented by
:func:`variant`, :func:`prepare`, :func:`event`, :func:`reflectance`,
:func:`transmittance`, :func:`has_specular` and :func:`body_factor`.
"""

from __future__ import annotations

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet.common import ABSORBED, SCATTERED, bracketed_below, reflect, reflectance_brackets
from vcavity.facet.fresnel_conductor import fresnel_conductor, fresnel_conductor_array
from vcavity.parameters import Number
from vcavity.rng import next_uniform

NAME = "conductor"
DESCRIPTION = ("conductor (metal) facets of complex index eta + i k: reflect with the exact Fresnel F, "
               "else absorbed; default gold at 548.6 nm (Johnson & Christy 1972)")
PARAMETERS = (
    Number("eta", "real part of the complex index eta + i k (default: gold at 548.6 nm, Johnson & Christy 1972)",
           lo=0.0, lo_open=True, default=0.43, example=0.43, default_unless="k"),
    Number("k", "extinction coefficient, the imaginary part of eta + i k (default: gold at 548.6 nm, "
                "Johnson & Christy 1972)", lo=0.0, default=2.455, example=2.455, default_unless="eta"),
)
# the defaults are one metal: gold's eta with another metal's k (or the reverse) is none, so
# a user who gives one of the two must give the other (docs/physics.md sec. 4)
VARIANTS = ("conductor",)
#: Named parameter sets as a user writes them in ``[material]``, covering every variant: the
#: conformance suite (tests/facet/test_conformance.py) runs every generic check on each.
EXAMPLES = {
    "gold": {"eta": 0.43, "k": 2.455},  # the default: 548.6 nm, Johnson & Christy 1972
    "gold_red": {"eta": 0.14, "k": 3.697},  # 659.5 nm, Johnson & Christy 1972
    "strong_absorber": {"eta": 0.05, "k": 20.0},
    "total_internal_reflection": {"eta": 0.7, "k": 0.0},  # eta < 1, no absorption: F = 1 near grazing
}

# facet data layout: [eta, k, F brackets (BRACKET_BINS x 2, flat)]
_ETA = 0
_K = 1
_BRACKETS = 2


def variant(values) -> int:
    """The only variant."""
    return 0


def prepare(values) -> np.ndarray:
    """Facet data for the kernel: ``[eta, k, F brackets...]`` (float64, see layout above)."""
    eta, k = float(values["eta"]), float(values["k"])
    brackets = reflectance_brackets(lambda c: fresnel_conductor_array(c, eta, k))
    return np.ascontiguousarray(np.concatenate([[eta, k], brackets.ravel()]), dtype=np.float64)


def has_specular(values) -> bool:
    """A conductor is all specular lobe (what is not reflected is absorbed)."""
    return True


def body_factor(values) -> float:
    """No body: 0."""
    return 0.0


@njit(cache=True)
def reflectance(cos_theta, data):
    """Specular reflectance ``F(cos, eta + i k)`` of the conductor (physics.md sec. 4)."""
    return fresnel_conductor(cos_theta, data[_ETA], data[_K])


@njit(cache=True)
def transmittance(cos_theta, data):
    """``T = 0``: what a conductor does not reflect it absorbs (no body term)."""
    return 0.0


@njit(cache=True, inline="always")
def _below_reflectance(u, cos_in, data):
    """Exactly ``u < F(cos_in)``, mostly decided from the bracketing table."""
    decided, below = bracketed_below(u, cos_in, data, _BRACKETS)
    if decided:
        return below
    return u < fresnel_conductor(cos_in, data[_ETA], data[_K])


@njit(cache=True, inline="always")
def event(variant, state, dx, dy, dz, cos_in, nx, nz, data):
    """One facet event: reflect with probability ``F(cos_in)``, else absorbed (one uniform).

    Arguments and results as :func:`vcavity.facet.interfaced_lambertian.event`;
    ``outcome`` is ``SCATTERED`` (the reflected direction) or ``ABSORBED``.
    """
    state, u = next_uniform(state)
    if _below_reflectance(u, cos_in, data):
        dx, dz = reflect(dx, dz, cos_in, nx, nz)
        return state, SCATTERED, dx, dy, dz
    return state, ABSORBED, dx, dy, dz
