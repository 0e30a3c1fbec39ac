"""Exact single-bounce albedo of the V-groove walk, for scripts/stress.py.

The simulated ``f1`` (paths leaving after exactly one facet event) has a closed-form
expectation up to a 3-D quadrature: with V-cavity masking the single-bounce model IS the
expectation of the walk (physics.md sec. 7). Per groove normal m (pdf D(m)(m.n), sampled
by the library's own map), the light entering the opening hits facet m with weight
``(i.m)/((m.n)(i.n))`` on a lit band ``G1_V(i, m)`` from the rim (H eq. 49); the specular
part escapes from the band ``G1_V(o, m)`` (IL eq. 14: ``min`` of the two), the body part
re-emerges (probability ``(1 - F) a``, physics.md sec. 4) with pdf ~ ``T(mu) mu`` and
escapes from ``min(G1_V(i), G1_V(o))``, averaged over o in closed form in the azimuth
and by Gauss-Legendre in mu. Sensor-independent; the error estimate is the distance to
the half-resolution grid (tests/test_stress_quick.py checks it covers the true error).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from vcavity._numba.jit import njit  # caches where vcavity's own code does

from vcavity.sensor.binning import direction_to_cell
from vcavity.config import Material, validate
from vcavity.facet import registry as facets
from vcavity.facet.fresnel import emergence_probability
from vcavity.microfacet import registry as distributions
from vcavity.simulate.pipeline import Scene, incident_vector


@njit(cache=True, inline="always")
def _normal(kind, u1, u2, params):
    """Normal sampled with pdf D(m)(m.n) by the library's map (physics.md sec. 2), for any
    registered distribution (``kind`` a run-time integer)."""
    return distributions.sample_normal(kind, u1, u2, params)


def reemission_probability(material: Material) -> float:
    """Probability that light transmitted into a facet's body re-emerges (physics.md sec. 4).

    From the facet's analytic terms (the body term ``K T(c_i) T(c_o)`` integrated over the
    exits): ``a = 2 pi K int_0^1 T(mu) mu dmu``, by Gauss-Legendre in ``mu = t^2`` (T rises
    fast near mu = 0 for eta -> 1); 0 for a facet without a body term (mirror, conductor).
    For the IL facet its closed form ``emergence_probability(kd, eta)`` (IL eq. 4-8 summed
    over the internal reflections; exactly 1 at kd = 1 for every eta).
    """
    if material.facet == "interfaced_lambertian":
        return float(emergence_probability(material.facet_params["kd"], material.facet_params["eta"]))
    factor = facets.body_factor(material.facet, material.facet_params)
    if factor == 0.0:
        return 0.0
    kind, _, data = facets.prepare(material.facet, material.facet_params)
    x, w = np.polynomial.legendre.leggauss(200)
    t, w = 0.5 * (x + 1.0), 0.5 * w
    mu = t * t  # mu dmu = 2 t^3 dt
    integral = sum(wk * 2.0 * tk**3 * facets.transmittance(kind, m, data) for m, tk, wk in zip(mu, t, w))
    return float(2.0 * math.pi * factor * integral)


@njit(cache=True)
def clipped_cos_average(a, b, g):
    """``(1/pi) int_0^pi clip(a - b cos psi, 0, g) dpsi`` in closed form (b >= 0, g >= 0)."""
    if not b > 0.0:
        return min(max(a, 0.0), g)
    c0 = min(max(a / b, -1.0), 1.0)  # psi0: where a - b cos psi = 0
    c1 = min(max((a - g) / b, -1.0), 1.0)  # psi1: where it reaches g
    p0 = math.acos(c0)
    p1 = math.acos(c1)
    s0 = math.sqrt((1.0 - c0) * (1.0 + c0))
    s1 = math.sqrt((1.0 - c1) * (1.0 + c1))
    return (a * (p1 - p0) - b * (s1 - s0) + g * (math.pi - p1)) / math.pi


@njit(cache=True)
def body_escape(mz, st, g, facet_kind, facet_data, gl_x, gl_w):
    """``E_o[min(g, G1_V(o, m))]`` for o leaving the facet's body (pdf ~ T(o.m)(o.m) with the
    facet's transmittance T, physics.md sec. 4; ``facet_kind`` a run-time integer): the fraction of a lit band ``[0, g]`` of the facet (from the rim) from which
    the emerging light escapes the groove without another bounce (IL eq. 12 with G2_V).

    In the facet frame ``o = mu m + sqrt(1-mu^2)(cos psi t1 + sin psi t2)`` gives
    ``G1_V = clip(2 mz^2 - 2 mz st sqrt(1-mu^2)/mu cos psi, 0, 1)`` (H eq. 49): the psi
    average is :func:`clipped_cos_average`; mu uses Gauss-Legendre on the three pieces
    between its kinks ``mu = st`` and ``B(mu) = |A - g|``, self-normalised.
    """
    if st <= 0.0 or mz <= 0.0:
        return g
    big_a = 2.0 * mz * mz
    kappa = abs(big_a - g) / (2.0 * mz * st)
    k2 = 1.0 / math.sqrt(1.0 + kappa * kappa)
    lo = min(st, k2)
    hi = max(st, k2)
    num = 0.0
    den = 0.0
    for piece in range(3):
        a = 0.0 if piece == 0 else (lo if piece == 1 else hi)
        b = lo if piece == 0 else (hi if piece == 1 else 1.0)
        if b <= a:
            continue
        for n in range(gl_x.shape[0]):
            tau = 0.5 * (gl_x[n] + 1.0)
            if piece == 0:  # mu = b tau^2 resolves T's rise near mu = 0 (eta -> 1)
                mu = b * tau * tau
                w = gl_w[n] * b * tau
            else:
                mu = a + (b - a) * tau
                w = 0.5 * gl_w[n] * (b - a)
            p = 2.0 * mu * facets.transmittance(facet_kind, mu, facet_data) * w
            big_b = 2.0 * mz * st * math.sqrt((1.0 - mu) * (1.0 + mu)) / mu
            num += p * clipped_cos_average(big_a, big_b, g)
            den += p
    return num / den if den > 0.0 else g


@njit(cache=True, inline="always")
def _across(kind, u1, u2, params, ix, iy):
    """Horizontal part of i.m: zero where the groove axis lies in the plane of incidence."""
    mx, my, _ = _normal(kind, u1, u2 - math.floor(u2), params)
    return ix * mx + iy * my


@njit(cache=True)
def _crossings(kind, u1, params, ix, iy):
    """The two u2 in [0, 1) where ``_across`` changes sign (azimuth maps are monotone)."""
    out = np.array([0.0, 0.5])
    found = 0
    n = 64
    prev = _across(kind, u1, 0.0, params, ix, iy)
    for k in range(1, n + 1):
        cur = _across(kind, u1, k / n, params, ix, iy)
        if found < 2 and (prev < 0.0) != (cur < 0.0):
            lo, hi = (k - 1) / n, k / n
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if (_across(kind, u1, mid, params, ix, iy) < 0.0) == (prev < 0.0):
                    lo = mid
                else:
                    hi = mid
            out[found] = 0.5 * (lo + hi)
            found += 1
        prev = cur
    if found < 2:  # normal incidence or a flat groove: any split point will do
        return 0.0, 0.5
    return out[0], out[1]


@njit(cache=True, parallel=True)
def _f1_grid(kind, params, ix, iy, iz, facet_kind, facet_data, emergence, n_t, gl_x, gl_w, spec_cell, resolution):
    """(f1 albedo, f1 share of the mirror cell from the specular term) on an n_t x 2n_t grid.

    u1 = 1 - (1-t)^2 (physics.md sec. 9); u2 in two pieces between the azimuths where the
    groove axis lies in the plane of incidence, nodes graded toward both ends
    (w = tau^3/(tau^3 + (1-tau)^3)): at grazing light the escape changes on a scale
    ~cos(theta_i) there, which a uniform grid misses. The facet reflects with its
    reflectance R(i.m) and transmits T(i.m) into its body, which re-emits with probability
    ``emergence``. ``kind`` and ``facet_kind`` are run-time integers (the registries' chain
    over every module, :mod:`vcavity._numba.dispatch`): one compile serves every material.
    With ``literally`` on both, each pair was a compile of its own (85 in the default suite,
    23 s), and each call ~3x slower (Numba's literal dispatch).
    """
    n_u2 = n_t  # per piece
    total = np.zeros(n_t)
    cell = np.zeros(n_t)
    for j in prange(n_t):
        t = (j + 0.5) / n_t
        u1 = 1.0 - (1.0 - t) * (1.0 - t)  # nodes toward grazing normals (physics.md sec. 9)
        c1, c2 = _crossings(kind, u1, params, ix, iy)
        acc = 0.0
        acc_cell = 0.0
        for piece in range(2):
            start = c1 if piece == 0 else c2
            length = (c2 - c1) if piece == 0 else (1.0 - (c2 - c1))
            for k in range(n_u2):
                tau = (k + 0.5) / n_u2
                p3 = tau * tau * tau
                q3 = (1.0 - tau) * (1.0 - tau) * (1.0 - tau)
                den = p3 + q3
                u2 = start + length * p3 / den
                dw = length * 3.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / (den * den) / n_u2
                mx, my, mz = _normal(kind, u1, u2 - math.floor(u2), params)
                im = ix * mx + iy * my + iz * mz
                if im <= 0.0:
                    continue
                hit = im / (mz * iz)  # facet area seen from i per unit opening (times G1)
                g_i = min(1.0, 2.0 * mz * iz / im)  # lit band from the rim (H eq. 49)
                f = facets.reflectance(facet_kind, im, facet_data)
                oz = 2.0 * im * mz - iz  # mirror direction o = 2 (i.m) m - i
                g_o = 0.0 if oz <= 0.0 else min(1.0, 2.0 * mz * oz / im)
                spec = f * hit * min(g_i, g_o) * dw
                acc += spec
                if oz > 0.0 and spec > 0.0:
                    ox = 2.0 * im * mx - ix
                    oy = 2.0 * im * my - iy
                    if direction_to_cell(ox, oy, oz, resolution) == spec_cell:
                        acc_cell += spec
                if emergence > 0.0:
                    st = math.sqrt(mx * mx + my * my)
                    acc += dw * hit * facets.transmittance(facet_kind, im, facet_data) * emergence * body_escape(
                        mz, st, g_i, facet_kind, facet_data, gl_x, gl_w)
        w = 2.0 * (1.0 - t) / n_t
        total[j] = acc * w
        cell[j] = acc_cell * w
    return total.sum(), cell.sum()


def f1_reference(material: dict, theta_deg: float, phi_deg: float = 0.0, n_t: int = 256,
                 resolution: int = 57):
    """Exact single-bounce albedo of the V-groove walk by quadrature (physics.md sec. 5, 7).

    Parameters
    ----------
    material : dict
        A config ``[material]`` table (validated here).
    theta_deg, phi_deg : float
        Incident direction in degrees.
    n_t : int, optional
        Grid rows in ``t`` (``u1 = 1 - (1-t)^2``); each row has ``2 n_t`` azimuth nodes.
    resolution : int, optional
        Sensor resolution N for the mirror-direction cell.

    Returns
    -------
    f1, f1_error, spec, spec_error : float
        The albedo of the paths that leave after exactly one bounce; the share of it
        (specular term only) in the sensor cell of the mirror direction ``(-i_x, -i_y,
        i_z)``; error estimates of both (distance to the half-resolution grid).
    """
    cfg = validate({"material": material, "incidence": {"theta_i_deg": [theta_deg], "phi_i_deg": phi_deg}})
    m = cfg.material
    scene = Scene.of(m)  # the parameter arrays and facet data the kernel gets
    emergence = reemission_probability(m)
    i = incident_vector(math.radians(theta_deg), math.radians(phi_deg))
    spec_cell = int(direction_to_cell(-i[0], -i[1], i[2], resolution))
    gl_x, gl_w = np.polynomial.legendre.leggauss(16)
    args = (scene.dist_kind, scene.params, i[0], i[1], i[2], scene.facet_kind, scene.facet_data, emergence)
    fine = _f1_grid(*args, n_t, gl_x, gl_w, spec_cell, resolution)
    coarse = _f1_grid(*args, n_t // 2, gl_x, gl_w, spec_cell, resolution)
    return fine[0], abs(fine[0] - coarse[0]), fine[1], abs(fine[1] - coarse[1])
