"""Tails of the Student-t marginal slope density: the STD's Smith ``Lambda`` and its
visible-slope sampler (physics.md sec. 10 and 14).

Every function takes the shape constants as scalars ``(z, inv_z, log_z, k, c)`` (the
entries 3..7 of :func:`vcavity.microfacet.student_t.params_from`'s array) so that the same
code serves the marginal slope density ``P2(q) = c (1 + q^2/z)^-(z + 1/2)`` of shape ``z``
and, with ``z + 1/2``, the conditional density of the cross slope (physics.md sec. 14).
``c = P2(0)`` and ``k = c z / (2 z - 1) = ∫_0^inf q P2(q) dq``.
"""

import math

from vcavity._numba.jit import njit

_CF_EPS = 2.0**-52
_CF_MAXIT = 1000
_FPMIN = 1e-300
_FAR = 1e150  # slopes beyond this are as good as infinite (tan theta_m is capped far below)


@njit(cache=True)
def betacf(a, b, x):
    """Lentz's continued fraction of ``I_x(a, b)`` (NR betacf); products reordered so that
    ``b`` up to 1e308 cannot overflow."""
    qab = a + b
    qap = a + 1.0
    qam = a - 1.0
    c = 1.0
    d = 1.0 - qab * x / qap
    if abs(d) < _FPMIN:
        d = _FPMIN
    d = 1.0 / d
    h = d
    for m in range(1, _CF_MAXIT):
        m2 = 2.0 * m
        aa = m * ((b - m) * x) / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        if abs(d) < _FPMIN:
            d = _FPMIN
        c = 1.0 + aa / c
        if abs(c) < _FPMIN:
            c = _FPMIN
        d = 1.0 / d
        h *= d * c
        aa = -(a + m) * ((qab + m) * x) / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        if abs(d) < _FPMIN:
            d = _FPMIN
        c = 1.0 + aa / c
        if abs(c) < _FPMIN:
            c = _FPMIN
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _CF_EPS:
            break
    return h


@njit(cache=True)
def gauss_cf(z, inv_a2):
    """``(E1, f)`` with ``G = 1 - 2F1(1, 1/2; z+1; -z/a^2) = E1/(E1 + f)``,
    ``f = 1 + E2/(1 + E3/(1 + ...))``.

    Gauss's continued fraction of 2F1(0+1, 1/2; z+1)/2F1(0, 1/2; z), whose coefficients
    ``E_{2n+1} = (n+1/2)(z+n) z / ((z+2n)(z+2n+1) a^2)`` and
    ``E_{2n} = n (z+n-1/2) z / ((z+2n-1)(z+2n) a^2)`` are all positive (modified Lentz).
    Both parts are returned so that ``1 - G = f/(E1 + f)`` is free of cancellation too.
    """
    e1 = 0.5 * (z / (z + 1.0)) * inv_a2
    f = 1.0
    c = 1.0
    d = 0.0
    for k in range(2, _CF_MAXIT):
        n = k // 2
        if k % 2 == 1:
            e = (n + 0.5) * ((z + n) / (z + 2.0 * n)) * (z / (z + 2.0 * n + 1.0)) * inv_a2
        else:
            e = n * ((z + n - 0.5) / (z + 2.0 * n - 1.0)) * (z / (z + 2.0 * n)) * inv_a2
        d = 1.0 / (1.0 + e * d)
        c = 1.0 + e / c
        delta = c * d
        f *= delta
        if abs(delta - 1.0) < _CF_EPS:
            break
    return e1, f


@njit(cache=True, inline="always")
def _log1p_a2(a, inv_z, log_z):
    """``(a^2, log(1 + a^2/z))``; ``a^2 = inf`` once it overflows (the log stays exact)."""
    if a < _FAR:
        a2 = a * a
        return a2, math.log1p(a2 * inv_z)
    return math.inf, 2.0 * math.log(a) - log_z


@njit(cache=True)
def lambda_of_a(a, z, inv_z, log_z, k, c):
    """Exact Smith ``Lambda(a) = (1/a) ∫_a^inf (q - a) P2(q) dq`` of the STD (physics.md sec. 10).

    ``Lambda = T1 - I_x(z, 1/2)/2``, ``T1 = k (1 + a^2/z)^(1/2 - z) / a``, ``x = z/(z + a^2)``:
    for ``a^2 < 1.5/(1 + 1/z)`` the incomplete beta from Lentz's fraction of
    ``I_{1-x}(1/2, z)``; above, ``Lambda = T1 (1 + (2z - 1) G)/(2z)`` with Gauss's fraction.
    ``inf`` for ``a = 0``; 0 for ``a = inf``.
    """
    if not a > 0.0:
        return math.inf
    if a == math.inf:
        return 0.0
    a2, lx = _log1p_a2(a, inv_z, log_z)
    t1 = k * math.exp(-(z - 0.5) * lx) / a
    # switch where NR's betacf needs the symmetry (measured: moving it to a^2 = 3 cuts the
    # Gauss iterations from ~150 to ~80 but raises the worst error from 5e-14 to 3e-13)
    if a2 < 1.5 / (1.0 + inv_z):
        # x > (z + 1)/(z + 5/2): I_x(z, 1/2) = 1 - I_y(1/2, z), y = 1 - x = a^2/(z + a^2)
        # y^(1/2) x^z / B(z, 1/2) = a P2(a) = c a x^(z + 1/2)
        front = c * a * math.exp(-(z + 0.5) * lx)
        return t1 - 0.5 + front * betacf(0.5, z, a2 / (z + a2))
    e1, f = gauss_cf(z, 1.0 / a2)
    g = e1 / (e1 + f)
    return t1 * (0.5 * inv_z + (1.0 - 0.5 * inv_z) * g)


@njit(cache=True)
def tail_parts(a, z, inv_z, log_z, k, c):
    """``(P(q < -a), ∫_a^inf (q - a) P2(q) dq)`` for a slope ``a >= 0`` (physics.md sec. 14).

    The second is ``a Lambda(a)``; both come from the fraction :func:`lambda_of_a` uses, with
    ``P(q < -a) = T1 - Lambda`` written without the subtraction: ``1/2 - a P2(a) B`` below
    the switch (``B`` Lentz's fraction) and ``(c/2) (1 + a^2/z)^(1/2 - z) (1 - G)/a`` above.
    """
    if not a > 0.0:
        return 0.5, k
    if a == math.inf:
        return 0.0, 0.0
    a2, lx = _log1p_a2(a, inv_z, log_z)
    decay = math.exp(-(z - 0.5) * lx)  # (1 + a^2/z)^(1/2 - z)
    if a2 < 1.5 / (1.0 + inv_z):
        front = c * a * math.exp(-(z + 0.5) * lx)
        tail = 0.5 - front * betacf(0.5, z, a2 / (z + a2))
        return tail, k * decay - a * tail
    e1, f = gauss_cf(z, 1.0 / a2)
    # k (1 - 1/(2z)) = c/2: no cancellation as z -> 1/2
    tail = 0.5 * c * decay / a * (f / (e1 + f))
    partial = k * decay * (0.5 * inv_z + (1.0 - 0.5 * inv_z) * (e1 / (e1 + f)))
    return tail, partial


@njit(cache=True, inline="always")
def _density(x, z, inv_z, log_z, c):
    """``P2(x) = c (1 + x^2/z)^-(z + 1/2)``."""
    _, lx = _log1p_a2(abs(x), inv_z, log_z)
    return c * math.exp(-(z + 0.5) * lx)


@njit(cache=True)
def visible_cdf(x, mu, z, inv_z, log_z, k, c):
    """``F(x) = ∫_-inf^x (mu - t) P2(t) dt`` for ``x <= mu``: the visible slope's CDF up to
    ``F(mu) = mu (1 + Lambda)`` (physics.md sec. 14), as a sum of non-negative terms.

    ``x < 0``: ``(mu - x) P(q < x) + |x| Lambda(|x|)``; ``x >= 0`` (then ``mu >= x``):
    ``mu P(q < x) + ∫_x^inf q P2``.
    """
    if x < 0.0:
        tail, partial = tail_parts(-x, z, inv_z, log_z, k, c)
        return (mu - x) * tail + partial
    tail, partial = tail_parts(x, z, inv_z, log_z, k, c)
    return mu * (1.0 - tail) + (partial + x * tail)


@njit(cache=True, inline="always")
def _middle(lo, hi):
    """Bisection point of ``[lo, hi]``: geometric when both ends are far on one side (the
    tails are heavy: a bracket may span many decades)."""
    if hi < -1.0 and lo < 4.0 * hi:
        return -math.sqrt(lo * hi)
    if lo > 1.0 and hi > 4.0 * lo:
        return math.sqrt(lo * hi)
    return 0.5 * (lo + hi)


@njit(cache=True)
def visible_slope(u, mu, z, inv_z, log_z, k, c):
    """The slope ``x <= mu`` with ``F(x) = u F(mu)`` (:func:`visible_cdf`).

    Newton on ``log F`` (``F' = (mu - x) P2(x)``) inside a bisection bracket, as for
    Beckmann; the bracket's far end moves out by factors of 16 (at most to ``-1e150``). Exact
    to rounding: the loop ends when the step or the bracket is within 4 ulp of ``x``.
    """
    target = math.log(max(u, 1e-300)) + math.log(visible_cdf(mu, mu, z, inv_z, log_z, k, c))
    hi = mu
    lo = min(mu, 0.0) - 1.0
    while math.log(max(visible_cdf(lo, mu, z, inv_z, log_z, k, c), 1e-320)) > target and lo > -_FAR:
        lo *= 16.0
    x = _middle(lo, hi)
    for _ in range(300):
        fx = visible_cdf(x, mu, z, inv_z, log_z, k, c)
        h = math.log(max(fx, 1e-320)) - target
        if h > 0.0:
            hi = x
        else:
            lo = x
        slope = (mu - x) * _density(x, z, inv_z, log_z, c)
        new = x - h * fx / slope if slope > 0.0 else lo - 1.0
        if not lo < new < hi:
            new = _middle(lo, hi)
        if abs(new - x) <= 4e-16 * (1.0 + abs(x)) or hi - lo <= 4e-16 * (1.0 + abs(x)):
            return new
        x = new
    return x


@njit(cache=True)
def lower_quantile(p, z, inv_z, log_z, k, c):
    """``a >= 0`` with ``P(q < -a) = p`` for ``p`` in ``(0, 1/2]`` (0 for ``p >= 1/2``).

    Newton on ``log P(q < -a)`` (derivative ``-P2(a)/P``) in a bisection bracket whose far
    end moves out by factors of 16 (at most to ``1e150``).
    """
    if p >= 0.5:
        return 0.0
    target = math.log(max(p, 1e-300))
    lo = 0.0
    hi = 1.0
    while math.log(max(tail_parts(hi, z, inv_z, log_z, k, c)[0], 1e-320)) > target and hi < _FAR:
        hi *= 16.0
    a = _middle(lo, hi)
    for _ in range(300):
        tail = tail_parts(a, z, inv_z, log_z, k, c)[0]
        h = math.log(max(tail, 1e-320)) - target
        if h > 0.0:
            lo = a
        else:
            hi = a
        dens = _density(a, z, inv_z, log_z, c)
        new = a + h * tail / dens if dens > 0.0 else hi + 1.0
        if not lo < new < hi:
            new = _middle(lo, hi)
        if abs(new - a) <= 4e-16 * (1.0 + a) or hi - lo <= 4e-16 * (1.0 + a):
            return new
        a = new
    return a
