"""Groove sampling from a point of the unit disk: the kernel's trig-free sampler.

``sample(u1, u2, params)`` of each distribution (physics.md sec. 2) builds the slope
direction from ``cos(2 pi u2), sin(2 pi u2)``; two libm calls are a large share of the
per-path cost. Here the kernel instead draws a point ``(a, b)`` uniformly in the unit
disk (by rejection from the square, no trig) and uses two facts (Marsaglia's polar
method): ``s = a^2 + b^2`` is uniform on (0, 1), and ``(a, b)/sqrt(s)`` is a uniform
unit vector independent of ``s``. With ``s = 1 - u1`` and ``(a, b)/sqrt(s) =
(cos 2 pi u2, sin 2 pi u2)`` each function below is *the same map* as the distribution's
``sample`` (tests/kernels/test_sampling.py checks that to 1e-12), so it samples
``D(m)(m.n)`` exactly.
"""

from __future__ import annotations

import math

from vcavity._jit import njit

from vcavity.microfacet import beckmann, gaussian, ggx, phong
from vcavity.microfacet.common import stretched_slope


@njit(cache=True, inline="always")
def groove_from_disk(dist_kind, a, b, s, params):
    """(tan theta_m, cos phi_m, sin phi_m) of a groove, from a disk point.

    Parameters
    ----------
    dist_kind : int
        ``KIND`` of the distribution module.
    a, b : float
        A point uniform in the open unit disk, not the centre. The kernel draws
        ``a, b = 2u - 1`` from 53-bit uniforms, so ``s >= 2**-104`` and every result
        is finite.
    s : float
        ``a*a + b*b``, in (0, 1).
    params : ndarray
        The distribution's ``make_params`` output.

    Returns
    -------
    tan_theta_m, cos_phi_m, sin_phi_m : float
        As the distribution's ``sample`` with ``u1 = 1 - s``.
    """
    if dist_kind == beckmann.KIND or dist_kind == ggx.KIND:
        # slope = (alpha_x a, alpha_y b) * r / sqrt(s); m = normalize(-slope, 1) (H sec. 5)
        if dist_kind == beckmann.KIND:
            r_over_sqrt_s = math.sqrt(-math.log(s) / s)  # r^2 = -log(1 - u1) = -log s
        else:
            r_over_sqrt_s = math.sqrt(1.0 - s) / s  # r^2 = u1/(1 - u1) = (1 - s)/s
        # stretched_slope is the plain formula for ordinary alpha and stays finite for
        # alpha down to 1e-300 and up to 1e300 (no under/overflow of the squares)
        return stretched_slope(r_over_sqrt_s, a, b, params[0], params[1])
    inv = 1.0 / math.sqrt(s)
    if dist_kind == phong.KIND:
        # cos^2 theta_m = s^(2/(alpha_p + 2)) (W eq. 31)
        tan2 = math.expm1(-2.0 * math.log(s) / (params[0] + 2.0))
        return math.sqrt(tan2), a * inv, b * inv
    # Gaussian: tabulated inverse CDF of theta_m (IL eq. 13)
    return math.tan(gaussian.inverse_cdf_theta(1.0 - s, params)), a * inv, b * inv
