"""The interfaced Lambertian (IL) facet: a Lambertian body of albedo ``kd`` under a flat
dielectric interface of relative index ``eta`` (IL eq. 4-8, physics.md sec. 4).

Its limits are compiled as variants of one facet event, so a scene pays only for what
it uses: ``eta = 1`` is a Lambertian facet (no Fresnel), ``kd = 0`` a specular
dielectric (no body), otherwise the full IL facet.

One facet event with incoming cosine ``c`` to the facet normal (physics.md sec. 4):

1. with probability ``F(c)`` (:func:`~vcavity.facet.fresnel.fresnel_dielectric`) the
   light is reflected specularly;
2. otherwise it enters the body and re-emerges with probability
   ``a = emergence_probability(kd, eta)`` (else it is absorbed);
3. the emerging direction has ``mu = cos`` with pdf ``2 mu T(mu)/(1 - r_e)`` and a
   uniform azimuth, sampled by rejection: a cosine-weighted proposal accepted with
   probability ``T(mu)``. (:func:`make_emergence_table` and
   :func:`sample_emergence_mu_table` give a loop-free inverse-CDF alternative for very
   large eta, where rejection accepts only ~1/1900 tries at eta = 1e4, physics.md sec. 9;
   the kernel does not use them yet.)

The facet interface (see :mod:`vcavity.facet.registry`) is implemented by
:func:`variant`, :func:`prepare`, :func:`event`, :func:`reflectance`,
:func:`transmittance`, :func:`has_specular` and :func:`body_factor`.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet.common import ABSORBED, BRACKET_BINS, SCATTERED, bracketed_below, reflect, reflectance_brackets
from vcavity.facet.fresnel import (
    emergence_probability,
    fresnel_dielectric,
    fresnel_dielectric_array,
    fresnel_transmittance,
    fresnel_transmittance_array,
    one_minus_r_e,
    r_e,
)
from vcavity.parameters import Number
from vcavity.rng import next_uniform

NAME = "interfaced_lambertian"
DESCRIPTION = ("Lambertian body (albedo kd) under a flat dielectric interface (index eta), IL eq. 4-8; "
               "eta = 1: Lambertian facets, kd = 0: specular dielectric")
PARAMETERS = (
    Number("kd", "albedo of the Lambertian body (0: specular dielectric)", lo=0.0, hi=1.0, example=0.9),
    Number("eta", "relative index of the interface (1: Lambertian facet)", lo=1.0, default=1.5,
           example=1.5),
)

# compile-time variants of the facet event (physics.md sec. 4, limits)
DIELECTRIC = 0  # kd = 0: reflect with probability F, else absorbed by the body
LAMBERTIAN = 1  # eta = 1: F = 0, re-emit with probability kd, cosine-weighted
FULL = 2  # the full IL facet
VARIANTS = ("specular dielectric", "lambertian", "interfaced lambertian")
#: Named parameter sets as a user writes them in ``[material]``, covering every variant: the
#: conformance suite (tests/facet/test_conformance.py) runs every generic check on each.
EXAMPLES = {
    "typical": {"kd": 0.9, "eta": 1.5},  # fig. 7(b) of the IL paper
    "white": {"kd": 1.0, "eta": 1.5},  # nothing absorbed
    "high_index": {"kd": 0.5, "eta": 1000.0},
    "dielectric": {"kd": 0.0, "eta": 1.5},  # the specular dielectric variant
    "lambertian": {"kd": 0.7, "eta": 1.0},  # the Lambertian variant
}

#: Bins of the Fresnel bracketing table over cos in [0, 1].
FRESNEL_BINS = BRACKET_BINS
# facet data layout: [eta, emergence probability a, F brackets (FRESNEL_BINS x 2, flat)]
_ETA = 0
_EMERGENCE = 1
_BRACKETS = 2

_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(8)


def variant(values) -> int:
    """The compiled variant for ``kd``, ``eta``: eta = 1 never evaluates Fresnel, kd = 0
    never samples the body."""
    if values["eta"] == 1.0:
        return LAMBERTIAN
    if values["kd"] == 0.0:
        return DIELECTRIC
    return FULL


def fresnel_brackets(eta: float) -> np.ndarray:
    """Lower and upper bounds of F(cos, eta) on each of ``FRESNEL_BINS`` cosine bins.

    A ``(FRESNEL_BINS, 2)`` array built by :func:`vcavity.facet.common.reflectance_brackets`
    from the dielectric F (physics.md sec. 4): the facet event decides ``u < F(cos)`` from
    it and evaluates F only between the bounds.
    """
    return reflectance_brackets(lambda c: fresnel_dielectric_array(c, float(eta)))


def prepare(values) -> np.ndarray:
    """Facet data for the kernel: ``[eta, a, F brackets...]`` (float64, see layout above)."""
    eta = float(values["eta"])
    head = [eta, float(emergence_probability(float(values["kd"]), eta))]
    return np.ascontiguousarray(np.concatenate([head, fresnel_brackets(eta).ravel()]), dtype=np.float64)


def has_specular(values) -> bool:
    """True when the interface reflects (eta > 1): a specular lobe exists."""
    return values["eta"] != 1.0


def body_factor(values) -> float:
    """``kd / (pi eta^2 (1 - kd r_i))`` of the body term (IL eq. 8, physics.md sec. 4, 9).

    With ``eta^2 (1 - r_i) = 1 - r_e`` the denominator is evaluated as
    ``pi (eta^2 (1 - kd) + kd (1 - r_e))``: a sum of non-negative terms, finite for every
    ``eta`` (``1 - r_i`` underflows from eta ~ 1e108, ``eta^2`` overflows from ~1e154;
    then the factor is correctly 0 for ``kd < 1``). 0 when ``kd = 0``.
    """
    kd, eta = float(values["kd"]), float(values["eta"])
    if kd == 0.0:
        return 0.0
    absorbing = 0.0
    if kd < 1.0:
        with np.errstate(over="ignore"):  # inf for eta > ~1.3e154: the factor is then 0
            absorbing = float(np.float64(eta) * np.float64(eta) * (1.0 - kd))
    return kd / (math.pi * (absorbing + kd * float(one_minus_r_e(eta))))


@njit(cache=True)
def reflectance(cos_theta, data):
    """Specular reflectance of the interface, ``F(cos, eta)`` (W eq. 22, IL eq. 7)."""
    return fresnel_dielectric(cos_theta, data[_ETA])


@njit(cache=True)
def transmittance(cos_theta, data):
    """Transmittance of the interface ``T = 1 - F`` (W eq. 22), without cancellation."""
    return fresnel_transmittance(cos_theta, data[_ETA])


@njit(cache=True, inline="always")
def _below_fresnel(u, cos_in, data):
    """Exactly ``u < F(cos_in, eta)``, mostly decided from the bracketing table."""
    decided, below = bracketed_below(u, cos_in, data, _BRACKETS)
    if decided:
        return below
    return u < fresnel_dielectric(cos_in, data[_ETA])


@njit(cache=True, inline="always")
def _emerge(state, variant, data, nx, nz):
    """Direction leaving the body through a facet of normal (nx, 0, nz).

    pdf proportional to T(w.m)(w.m) (physics.md sec. 4): a cosine-weighted direction
    (uniform point (a, b) in the unit disk, mu = sqrt(1 - a^2 - b^2)), accepted with
    probability T(mu) = 1 - F(mu) when the interface is a dielectric (eta > 1).
    Tangents: t1 = (nz, 0, -nx), t2 = (0, 1, 0).
    """
    while True:
        state, ua = next_uniform(state)
        state, ub = next_uniform(state)
        a = 2.0 * ua - 1.0
        b = 2.0 * ub - 1.0
        rho2 = a * a + b * b
        if rho2 >= 1.0:
            continue
        mu = math.sqrt(1.0 - rho2)
        if variant == FULL:
            # accept with probability T(mu) = 1 - F(mu): reject when 1 - ut < F(mu)
            state, ut = next_uniform(state)
            if _below_fresnel(1.0 - ut, mu, data):
                continue
        return state, a * nz + mu * nx, b, mu * nz - a * nx


@njit(cache=True, inline="always")
def event(variant, state, dx, dy, dz, cos_in, nx, nz, data):
    """One facet event of the analog walk (physics.md sec. 4); see the module docstring.

    Parameters
    ----------
    variant : int
        ``DIELECTRIC``, ``LAMBERTIAN`` or ``FULL`` (a compile-time constant).
    state : uint64
        Random stream state (:mod:`vcavity.rng`).
    dx, dy, dz : float
        Direction of travel in the groove frame.
    cos_in : float
        ``-(d.n) > 0`` with the facet normal ``n = (nx, 0, nz)``.
    nx, nz : float
        The facet normal.
    data : ndarray
        :func:`prepare` output.

    Returns
    -------
    state, outcome, dx, dy, dz
        ``outcome`` is ``SCATTERED`` (new direction returned) or ``ABSORBED``.
    """
    if variant == LAMBERTIAN:
        reflected = False
    else:
        state, u = next_uniform(state)
        reflected = _below_fresnel(u, cos_in, data)
    if reflected:
        dx, dz = reflect(dx, dz, cos_in, nx, nz)
        return state, SCATTERED, dx, dy, dz
    if variant == DIELECTRIC:
        return state, ABSORBED, dx, dy, dz
    # enters the body; re-emerges with probability a (== 1.0 exactly when kd == 1)
    state, u = next_uniform(state)
    if u >= data[_EMERGENCE]:
        return state, ABSORBED, dx, dy, dz
    state, dx, dy, dz = _emerge(state, variant, data, nx, nz)
    return state, SCATTERED, dx, dy, dz


def _integrate_emergence_pdf(lo, hi, eta):
    """``int_lo^hi 2 t T(t) dt`` elementwise by 8-point Gauss-Legendre (unnormalised)."""
    half = 0.5 * (hi - lo)
    mid = 0.5 * (hi + lo)
    t = mid[..., None] + half[..., None] * _GAUSS_NODES
    integrand = 2.0 * t * fresnel_transmittance_array(t, eta)
    return half * (integrand @ _GAUSS_WEIGHTS)


def make_emergence_table(eta, n=4097):
    """Tabulate the inverse CDF of the emergence cosine, pdf ``2 mu T(mu)/(1 - r_e)``.

    Parameters
    ----------
    eta : float
        Relative index (>= 1).
    n : int, optional
        Number of nodes (>= 2). Node ``k`` holds ``mu`` with ``CDF(mu) = w_k^2``,
        ``w_k = k/(n-1)``: uniform in ``w = sqrt(u)``, which keeps the inverse smooth
        where the pdf vanishes at ``mu = 0``. With the default, linear interpolation in
        :func:`sample_emergence_mu_table` has max |CDF error| below 2e-8 (tested < 1e-6
        for eta from 1 to 1000).

    Returns
    -------
    numpy.ndarray
        float64 array of shape ``(n,)``, increasing from 0 to 1.

    Notes
    -----
    The forward CDF is integrated on a grid ``mu_j = (j/M)^2`` (fine near 0, where T
    varies on the scales ``sqrt(eta^2-1)`` for eta near 1 and ``1/eta`` for large eta)
    with 8-point Gauss-Legendre per cell, checked against ``1 - r_e`` (IL eq. 10), and
    inverted per node by bisection to double precision.
    """
    n = int(n)
    if n < 2:
        raise ValueError("n must be >= 2")
    eta = float(eta)
    if not eta >= 1.0:
        raise ValueError("eta must be >= 1")
    n_cells = max(16 * (n - 1), 16384)
    grid = (np.arange(n_cells + 1, dtype=np.float64) / n_cells) ** 2
    cdf = np.concatenate(([0.0], np.cumsum(_integrate_emergence_pdf(grid[:-1], grid[1:], eta))))
    total = cdf[-1]
    expected = 1.0 - r_e(eta)  # int_0^1 2 t T(t) dt = 1 - r_e
    if abs(total - expected) > 1e-12 * expected:
        raise RuntimeError(f"emergence CDF quadrature failed: {total!r} vs {expected!r}")
    targets = (np.arange(n, dtype=np.float64) / (n - 1)) ** 2 * total
    cell = np.clip(np.searchsorted(cdf, targets, side="right") - 1, 0, n_cells - 1)
    lo = grid[cell].copy()
    hi = grid[cell + 1].copy()
    base = cdf[cell]
    anchor = lo.copy()
    for _ in range(60):  # bisection: the bracket shrinks below one ulp of mu
        mid = 0.5 * (lo + hi)
        below = base + _integrate_emergence_pdf(anchor, mid, eta) < targets
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    table = 0.5 * (lo + hi)
    table[0] = 0.0
    table[-1] = 1.0
    return np.maximum.accumulate(table)


@njit(cache=True)
def sample_emergence_mu_table(u, table):
    """Sample the emergence cosine ``mu`` (pdf ``2 mu T(mu)/(1 - r_e)``) from a table.

    Inverse-CDF sampling (physics.md sec. 4, 9): ``w = sqrt(u)`` is located among the
    table's uniform ``w`` nodes and ``mu`` is interpolated linearly.

    Parameters
    ----------
    u : float
        Uniform random number in [0, 1).
    table : numpy.ndarray
        Output of :func:`make_emergence_table` for the facet's eta.

    Returns
    -------
    float
        mu in [0, 1].
    """
    last = table.shape[0] - 1
    x = math.sqrt(u) * last
    k = int(x)
    if k > last - 1:
        k = last - 1
    frac = x - k
    return table[k] + frac * (table[k + 1] - table[k])
