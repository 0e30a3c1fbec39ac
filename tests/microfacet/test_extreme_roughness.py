"""Beckmann and GGX ``D`` over the whole accepted roughness range (any float > 0).

Before, ``alpha = 1e-300`` divided by ``alpha^2 = 0`` inside the jitted ``D`` (a
``ZeroDivisionError`` that surfaced as ``SystemError`` in ``vcavity compare``). The
reference is the closed form (H eq. 82 and 85) evaluated with Python's ``decimal`` at 60
digits, which has no under- or overflow: independent of the float64 code.
"""

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest

from vcavity.microfacet import beckmann, ggx

getcontext().prec = 60
_PI = Decimal("3.14159265358979323846264338327950288419716939937510582097494")


def reference(name, m, ax, ay):
    mx, my, mz = (Decimal(float(c)) for c in m)
    ax, ay = Decimal(ax), Decimal(ay)
    if name == "beckmann":  # exp(-tan^2 (cos^2/ax^2 + sin^2/ay^2)) / (pi ax ay cos^4)
        e = (mx * mx / (ax * ax) + my * my / (ay * ay)) / (mz * mz)
        return (-e).exp() / (_PI * ax * ay * mz ** 4)
    s = mx * mx / (ax * ax) + my * my / (ay * ay) + mz * mz  # GGX, multiplied through by cos^4
    return 1 / (_PI * ax * ay * s * s)


@pytest.mark.parametrize("module", [beckmann, ggx], ids=["beckmann", "ggx"])
def test_D_matches_the_closed_form_for_any_roughness(module):
    rng = np.random.default_rng(5)
    for ax in (1e-300, 1e-200, 1e-60, 1e-4, 0.5, 3.0, 1e60, 1e200, 1e300):
        for ay in (ax, min(7.0 * ax, 1.7e308)):
            for k in range(40):
                tan = 0.0 if k == 0 else 10.0 ** rng.uniform(-300, 300) if k % 2 else 10.0 ** rng.uniform(-4, 2)
                phi = rng.uniform(0.0, 2.0 * math.pi)
                mz = 1.0 / math.sqrt(1.0 + tan * tan) if tan < 1e150 else 1.0 / tan
                sin = tan * mz if tan < 1e150 else 1.0
                m = (sin * math.cos(phi), sin * math.sin(phi), mz)
                value = module.D(m[0], m[1], m[2], np.array([ax, ay]))
                exact = reference(module.NAME, m, ax, ay)
                if exact > Decimal("1.7e308"):
                    assert value == math.inf
                elif exact < Decimal("1e-300"):
                    assert 0.0 <= value <= 1e-290
                else:
                    # the condition number of exp(-e) is e (up to ~1e3 here): 1e-12 is round-off
                    assert value == pytest.approx(float(exact), rel=1e-11), (ax, ay, tan)
