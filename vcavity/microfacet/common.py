"""Masking/shadowing functions shared by every microfacet distribution.

Conventions (physics.md sec. 1): macrosurface normal ``n = (0, 0, 1)``, all
directions point away from the surface, vectors are passed as three floats.

V-cavity (Torrance-Sparrow) masking is a function of the directions only
(physics.md sec. 3, H eq. 49, IL eq. 14).  Smith masking depends on the
distribution through its ``Lambda`` (each distribution module provides
``smith_lambda``); the Smith forms below take the Lambda values and leave the
sidedness factors ``chi+(v.m)`` to the caller.

Every function here is jitted (``vcavity._numba.jit.njit(cache=True)``) except
:func:`normal_sampler`, which derives a distribution's ``sample_normal`` from its
``sample``; vectorised evaluation of the distributions is in
:mod:`vcavity.microfacet.registry`.
"""

import math
import sys

import numpy as np

from vcavity._numba.jit import njit

#: Largest ``tan theta_m`` a sampler returns. Larger tangents (Beckmann/GGX with
#: ``alpha`` near the float64 maximum) are clamped: the groove is vertical to within
#: 1e-300 rad either way, and every product the V-groove walk forms with it stays finite.
MAX_TAN_THETA = 1e300

# ``cx^2 + cy^2`` is computed plainly when ``|slope|/r`` lies in this range (all
# realistic roughness); outside it the squares would under- or overflow.
_PLAIN_NORM_MIN = 1e-150
_PLAIN_NORM_MAX = 1e150
_LN2 = math.log(2.0)


def alpha_params_from(values):
    """Parameter array ``[alpha_x, alpha_y]`` of a distribution parameterised by its roughness alone.

    Beckmann and GGX share it (their ``params_from``).

    Parameters
    ----------
    values : mapping
        ``alpha_x``, ``alpha_y`` (> 0), as :class:`~vcavity.parameters.Roughness` returns them
        (validated upstream).

    Returns
    -------
    ndarray, shape (2,)
    """
    return np.array([values["alpha_x"], values["alpha_y"]], dtype=np.float64)


def alpha_lobe_width(values):
    """Angular roughness scale for quadratures: the smaller alpha (radians of theta_m)."""
    return float(min(values["alpha_x"], values["alpha_y"]))

@njit(cache=True)
def g1_vcavity(vx, vy, vz, mx, my, mz):
    """V-cavity masking ``G1_V(v, m)`` (H eq. 49, physics.md sec. 3).

    ``G1_V = chi+(v.m) max(0, min(1, 2 (m.n)(v.n) / (v.m)))``.  The outer
    ``max(0, .)`` (IL eq. 14) makes directions below the macrosurface masked.

    Parameters
    ----------
    vx, vy, vz : float
        Unit direction ``v`` (pointing away from the surface).
    mx, my, mz : float
        Unit microfacet normal ``m``.

    Returns
    -------
    float
        Fraction of the facet ``m`` visible from ``v``, in ``[0, 1]``; 0 when
        ``v`` is backfacing (``v.m <= 0``).
    """
    vm = vx * mx + vy * my + vz * mz
    if vm <= 0.0:
        return 0.0
    g = 2.0 * mz * vz / vm
    if g >= 1.0:
        return 1.0
    if g <= 0.0:
        return 0.0
    return g


@njit(cache=True)
def g2_vcavity(ix, iy, iz, ox, oy, oz, mx, my, mz):
    """V-cavity masking-shadowing ``G2_V = min(G1_V(i, m), G1_V(o, m))`` (IL eq. 14).

    Parameters
    ----------
    ix, iy, iz : float
        Unit direction toward the light.
    ox, oy, oz : float
        Unit direction toward the viewer.
    mx, my, mz : float
        Unit microfacet normal.

    Returns
    -------
    float
        Joint visibility in ``[0, 1]`` (physics.md sec. 3).
    """
    gi = g1_vcavity(ix, iy, iz, mx, my, mz)
    go = g1_vcavity(ox, oy, oz, mx, my, mz)
    return gi if gi < go else go


@njit(cache=True)
def g1_smith(lambda_v):
    """Smith masking ``G1_S = 1 / (1 + Lambda(v))`` (H eq. 43).

    The sidedness factor ``chi+(v.m)`` is NOT included: the caller multiplies
    by it.  ``lambda_v = inf`` (grazing, or a distribution whose Smith Lambda
    diverges) gives 0.

    Parameters
    ----------
    lambda_v : float
        Smith ``Lambda`` of the direction, from ``<distribution>.smith_lambda``.

    Returns
    -------
    float
        ``1 / (1 + lambda_v)``.
    """
    return 1.0 / (1.0 + lambda_v)


@njit(cache=True)
def g2_smith_separable(lambda_i, lambda_o):
    """Separable Smith shadowing-masking ``G1_S(i) G1_S(o)`` (H eq. 98).

    ``chi+(i.m) chi+(o.m)`` is left to the caller.

    Parameters
    ----------
    lambda_i, lambda_o : float
        Smith ``Lambda`` of the incident and outgoing directions.

    Returns
    -------
    float
        ``1 / ((1 + lambda_i)(1 + lambda_o))``.
    """
    return 1.0 / ((1.0 + lambda_i) * (1.0 + lambda_o))


@njit(cache=True)
def g2_smith_height_correlated(lambda_i, lambda_o):
    """Height-correlated Smith shadowing-masking (H eq. 99).

    ``G2 = 1 / (1 + Lambda(i) + Lambda(o))``; ``chi+(i.m) chi+(o.m)`` is left
    to the caller.

    Parameters
    ----------
    lambda_i, lambda_o : float
        Smith ``Lambda`` of the incident and outgoing directions.

    Returns
    -------
    float
        ``1 / (1 + lambda_i + lambda_o)``.
    """
    return 1.0 / (1.0 + lambda_i + lambda_o)




@njit(cache=True)
def normal_from_slope_angle(tan_theta, cos_phi, sin_phi):
    """Unit normal from ``(tan theta_m, cos phi_m, sin phi_m)`` (physics.md sec. 1).

    Parameters
    ----------
    tan_theta : float
        ``tan theta_m >= 0`` (finite; any size).
    cos_phi, sin_phi : float
        Unit azimuth pair.

    Returns
    -------
    mx, my, mz : float
        ``(sin theta cos phi, sin theta sin phi, cos theta)``.
    """
    if tan_theta < 1e150:
        mz = 1.0 / np.sqrt(1.0 + tan_theta * tan_theta)
        sin_theta = tan_theta * mz
    else:  # tan^2 would overflow (mz = 0, |m| = 0); 1/sqrt(1 + t^2) = 1/t to 1e-300
        mz = 1.0 / tan_theta
        sin_theta = 1.0
    return sin_theta * cos_phi, sin_theta * sin_phi, mz


# The body every distribution's sample_normal shares, on one line: each derived function is
# compiled as if written on the line that derives it, so tracebacks point there.
_SAMPLE_NORMAL_SOURCE = ("def sample_normal(u1, u2, params): "
                         "t, c, s = sample(u1, u2, params); return normal_from_slope_angle(t, c, s)\n")

_SAMPLE_NORMAL_DOC = """Unit normal sampled with pdf ``D(m)(m.n)``: the module's ``sample`` as a normal.

    Derived by :func:`vcavity.microfacet.common.normal_sampler`.

    Parameters
    ----------
    u1, u2 : float
        Uniforms in ``[0, 1)``.
    params : ndarray
        The distribution's parameter array (its ``params_from``).

    Returns
    -------
    mx, my, mz : float
        Unit microfacet normal with ``mz > 0``.
    """


@njit(cache=True)
def visible_normal(cos_v, sin_v, x, y, alpha_x, alpha_y):
    """The unit normal of the unit-roughness slopes ``x`` (along the stretched view's azimuth
    ``(cos_v, sin_v)``) and ``y`` (across it), stretched back to ``(alpha_x, alpha_y)``: the
    last step of every visible-normal sampler (physics.md sec. 14). Normalised after scaling
    by the largest component, so heavy-tailed slopes cannot overflow (for slopes whose
    components stay below 1 the result is the plain ``normalize(mx, my, 1)`` bit for bit).
    """
    mx = -alpha_x * (cos_v * x - sin_v * y)
    my = -alpha_y * (sin_v * x + cos_v * y)
    big = max(abs(mx), abs(my), 1.0)
    mx, my, mz = mx / big, my / big, 1.0 / big
    norm = math.sqrt(mx * mx + my * my + mz * mz)
    return mx / norm, my / norm, mz / norm


def normal_sampler(sample):
    """The distribution's ``sample_normal``: ``normal_from_slope_angle(*sample(u1, u2, params))``.

    Called once per distribution module, as ``sample_normal = normal_sampler(sample)``.
    The function returned belongs to that module, for Numba's on-disk cache as for
    tracebacks: its source file and line are those of the call and its module that of
    the caller, and ``sample`` is a global of the function, not a closure cell. So its
    cache files are named and invalidated like those of a function written in that module
    (editing the module recompiles it), and a second process loads it from the cache: a
    dispatcher in a closure cell would enter Numba's cache key with a per-process id,
    and every process would compile it again.

    Parameters
    ----------
    sample : numba dispatcher
        The module's jitted ``sample(u1, u2, params) -> (tan_theta_m, cos_phi_m, sin_phi_m)``.

    Returns
    -------
    numba dispatcher
        Jitted ``sample_normal(u1, u2, params) -> (mx, my, mz)`` with ``cache=True``.
    """
    caller = sys._getframe(1)
    scope = {"__name__": caller.f_globals["__name__"], "sample": sample,
             "normal_from_slope_angle": normal_from_slope_angle}
    source = "\n" * (caller.f_lineno - 1) + _SAMPLE_NORMAL_SOURCE
    exec(compile(source, caller.f_code.co_filename, "exec"), scope)
    function = scope["sample_normal"]
    function.__doc__ = _SAMPLE_NORMAL_DOC
    return njit(cache=True)(function)


@njit(cache=True, inline="always")
def ratio_squared(a, b, c):
    """``(a / (b c))^2`` for finite ``b, c > 0`` with no intermediate under- or overflow.

    Mantissas and exponents are taken apart (``frexp``), so the result is correctly
    rounded to a few ulp wherever it is a normal float, 0 where it underflows and ``inf``
    where it overflows (the distributions' D for alpha beyond [1e-50, 1e50]).
    """
    if a == 0.0:
        return 0.0
    fa, ea = math.frexp(abs(a))
    fb, eb = math.frexp(b)
    fc, ec = math.frexp(c)
    q = fa / (fb * fc)  # in (0.5, 8)
    e = 2 * (ea - eb - ec)
    if e > 1100:
        return math.inf
    if e < -1200:
        return 0.0
    return math.ldexp(q * q, e)


@njit(cache=True, inline="always")
def log_ratio_squared(a, b):
    """``log((a / b)^2)`` for finite ``b > 0``, from exact exponents; ``-inf`` for ``a = 0``."""
    if a == 0.0:
        return -math.inf
    fa, ea = math.frexp(abs(a))
    fb, eb = math.frexp(b)
    return 2.0 * (math.log(fa / fb) + (ea - eb) * _LN2)


@njit(cache=True)
def stretched_slope(r, cos_u, sin_u, alpha_x, alpha_y):
    """Slope-space sample ``r (alpha_x cos_u, alpha_y sin_u)`` as (tan theta_m, cos phi_m, sin phi_m).

    Stretching of the isotropic unit-roughness slope (H sec. 5, physics.md sec. 2);
    the normal is ``normalize(-s_x, -s_y, 1)``, so ``phi_m`` points against the slope.
    For ``|slope|/r`` within ``[1e-150, 1e150]`` this is the plain formula; outside it
    both components are scaled by one power of two so that no product or square under-
    or overflows, and the tangent is clamped to :data:`MAX_TAN_THETA`.

    Parameters
    ----------
    r : float
        Unit-roughness slope magnitude (>= 0, finite).
    cos_u, sin_u : float
        Azimuth of the unit-roughness slope: a unit pair, or any non-zero multiple
        ``c (cos, sin)`` of one, which then multiplies the tangent by ``c`` (a disk
        point ``(a, b)`` with ``r / sqrt(a^2 + b^2)``, as the kernel's trig-free sampler
        uses, gives the same result).
    alpha_x, alpha_y : float
        Roughness (> 0).

    Returns
    -------
    tan_theta_m, cos_phi_m, sin_phi_m : float
        Finite ``tan >= 0`` and a unit azimuth pair.
    """
    cx = alpha_x * cos_u
    cy = alpha_y * sin_u
    q = math.sqrt(cx * cx + cy * cy)
    if _PLAIN_NORM_MIN < q < _PLAIN_NORM_MAX:
        return r * q, -cx / q, -cy / q
    # Beyond the plain range: scale both components by the same power of two, taken from
    # the exponents of the factors, so neither the products nor their squares leave the
    # normal float range (no subnormal loses the azimuth's precision).
    fax, eax = math.frexp(alpha_x)
    fcx, ecx = math.frexp(cos_u)
    fay, eay = math.frexp(alpha_y)
    fcy, ecy = math.frexp(sin_u)
    ex = eax + ecx
    ey = eay + ecy
    if fcx == 0.0:
        ex = ey
    if fcy == 0.0:
        ey = ex
    e = max(ex, ey)
    sx = math.ldexp(fax * fcx, ex - e)  # one of the two is in [1/4, 1) in magnitude
    sy = math.ldexp(fay * fcy, ey - e)
    qs = math.hypot(sx, sy)
    tan_theta = math.ldexp(r * qs, e)  # inf when it overflows: clamped below
    if not tan_theta <= MAX_TAN_THETA:
        tan_theta = MAX_TAN_THETA
    return tan_theta, -sx / qs, -sy / qs
