"""Normal and exponential deviates from a random stream by the ziggurat method
(Marsaglia and Tsang, "The ziggurat method for generating random variables", J. Stat.
Softw. 5(8), 2000; physics.md sec. 15 says where the Smith walk uses them).

The density's graph (``exp(-x^2/2)`` or ``exp(-x)`` on ``x >= 0``) is covered by ``N = 256``
horizontal layers of equal area ``v``: layer 0 is the base, the rectangle
``[0, v/f(r)] x [0, f(r)]``, whose part beyond ``r`` stands for the tail; layer ``i >= 1`` is
``[0, x_i] x [f(x_i), f(x_{i+1})]`` with ``x_1 = r``, ``f(x_{i+1}) = f(x_i) + v/x_i`` and
``x_256 = 0``. A point uniform in a random layer under the curve is a deviate: draw the layer
``i`` and ``x = u x_i``; below ``x_{i+1}`` the point is under the curve whatever its height
(98.8 % of draws for the normal, 98.9 % for the exponential: one 64-bit draw of the stream,
a multiplication and a comparison, no ``log``); else it is in the layer's wedge, kept if a
height uniform in the layer falls under ``f(x)``, or it is beyond ``r`` in the base and is
drawn from the tail exactly (the exponential's tail is ``r`` plus an exponential deviate; the
normal's by Marsaglia's 1964 method). A rejected draw starts again, so the deviates are exact
up to the rounding of the tables, which are exact to ~1e-15 (``r`` and ``v`` from a
40-digit solution of ``f(x_255) + v/x_255 = 1``; tests/rng/test_ziggurat.py).

One 64-bit draw gives the layer (its low 8 bits), the normal's sign (bit 8) and a 53-bit
uniform (its high 53 bits): disjoint bits of the same word.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.rng import next_bits, next_uniform

N_LAYERS = 256
_LAYER_MASK = np.uint64(N_LAYERS - 1)
_SIGN_BIT = np.uint64(N_LAYERS)
_S11 = np.uint64(11)
_TWO_M53 = 1.0 / 9007199254740992.0  # 2^-53

#: ``r`` (the base layer's corner) and ``v`` (each layer's area) for ``N_LAYERS`` layers,
#: from a 40-digit bisection (Marsaglia and Tsang 2000 give the same to 16 digits).
NORMAL_R = 3.654152885361009
NORMAL_V = 0.004928673233974656
EXPONENTIAL_R = 7.697117470131049
EXPONENTIAL_V = 0.003949659822581559


def _layers(f, f_inverse, r, v):
    """``(width, inner, height)`` of each layer: ``width[i] = x_i`` (the base's ``v/f(r)``),
    ``inner[i] = x_{i+1}/x_i`` (the share of the layer wholly under the curve) and
    ``height[i] = f(x_i)`` with ``height[N] = f(0) = 1``."""
    x = np.empty(N_LAYERS + 1)
    x[0] = v / f(r)
    x[1] = r
    for i in range(1, N_LAYERS - 1):
        x[i + 1] = f_inverse(f(x[i]) + v / x[i])
    x[N_LAYERS] = 0.0
    height = np.array([f(r)] + [f(xi) for xi in x[1:N_LAYERS]] + [1.0])
    return x[:N_LAYERS].copy(), x[1:] / x[:N_LAYERS], height


_NORMAL_WIDTH, _NORMAL_INNER, _NORMAL_HEIGHT = _layers(
    lambda x: math.exp(-0.5 * x * x), lambda y: math.sqrt(-2.0 * math.log(y)), NORMAL_R, NORMAL_V)
_EXP_WIDTH, _EXP_INNER, _EXP_HEIGHT = _layers(
    lambda x: math.exp(-x), lambda y: -math.log(y), EXPONENTIAL_R, EXPONENTIAL_V)


@njit(cache=True)
def normal_tail(state):
    """The standard normal conditioned on ``x > NORMAL_R``, by Marsaglia's 1964 method:
    ``r + t`` with ``t`` exponential of rate ``r``, kept with probability ``exp(-t^2/2)``.

    Returns ``(state, x)``.
    """
    while True:
        state, u1 = next_uniform(state)
        state, u2 = next_uniform(state)
        t = -math.log(1.0 - u1) / NORMAL_R
        if -2.0 * math.log(1.0 - u2) > t * t:
            return state, NORMAL_R + t


@njit(cache=True)
def exponential_tail(state):
    """The exponential conditioned on ``x > EXPONENTIAL_R``: ``r`` plus an exponential
    deviate (memoryless). Returns ``(state, x)``."""
    state, u = next_uniform(state)
    return state, EXPONENTIAL_R - math.log(1.0 - u)


@njit(cache=True)
def standard_normal(state):
    """A standard normal deviate (density ``exp(-x^2/2)/sqrt(2 pi)``) from the stream.

    Parameters
    ----------
    state : uint64
        Random stream state (:mod:`vcavity.rng`).

    Returns
    -------
    state, x
        The advanced state and the deviate.
    """
    while True:
        state, bits = next_bits(state)
        i = np.intp(bits & _LAYER_MASK)
        u = np.float64(bits >> _S11) * _TWO_M53
        x = u * _NORMAL_WIDTH[i]
        if u < _NORMAL_INNER[i]:
            return state, -x if bits & _SIGN_BIT else x
        if i == 0:
            state, x = normal_tail(state)
            return state, -x if bits & _SIGN_BIT else x
        state, u = next_uniform(state)
        lower = _NORMAL_HEIGHT[i]
        if lower + u * (_NORMAL_HEIGHT[i + 1] - lower) < math.exp(-0.5 * x * x):
            return state, -x if bits & _SIGN_BIT else x


@njit(cache=True)
def standard_exponential(state):
    """An exponential deviate of rate 1 (density ``exp(-x)``, ``x >= 0``) from the stream:
    ``-log(1 - u)`` without the ``log`` for 98.9 % of draws.

    Parameters
    ----------
    state : uint64
        Random stream state (:mod:`vcavity.rng`).

    Returns
    -------
    state, x
        The advanced state and the deviate.
    """
    while True:
        state, bits = next_bits(state)
        i = np.intp(bits & _LAYER_MASK)
        u = np.float64(bits >> _S11) * _TWO_M53
        x = u * _EXP_WIDTH[i]
        if u < _EXP_INNER[i]:
            return state, x
        if i == 0:
            return exponential_tail(state)
        state, u = next_uniform(state)
        lower = _EXP_HEIGHT[i]
        if lower + u * (_EXP_HEIGHT[i + 1] - lower) < math.exp(-x):
            return state, x


__all__ = ["standard_normal", "standard_exponential", "N_LAYERS"]
