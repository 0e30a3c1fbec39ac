"""Beckmann's own stream sampler of visible normals (``beckmann.sample_visible_stream``, the Smith
walk's, physics.md sec. 14): each piece of its mixture, against the density, by chi-square.

(Every ``sample_visible`` and ``sample_visible_stream`` of every distribution, on every example
of the module, is checked in tests/microfacet/test_conformance.py; here are the cases that
reach each piece of Beckmann's mixture.) The density of the normals seen from ``v`` is
``<v, m>+ D(m)`` up to a constant. The test bins 4e5 samples per case on a grid of
``(θ_m, φ_m)`` cells (the θ edges stretched by the roughness so that every cell holds paths)
and compares them with the cell integrals of ``<v, m>+ D(m)`` by 12 x 12-point
Gauss-Legendre per cell, with D from tests/reference/materials.ndf (plain NumPy, independent
of the package), normalised by their sum. Cells expecting fewer than 10 samples are pooled
into one. Each case fails at p < 1e-4 (false-positive rate 1e-4 per case, 1e-3 for the
file's 10 cases; fixed seeds make the outcome deterministic). The sampler gets ``Lambda(v)``
from the plain-NumPy Smith walk's ``smith_lambda`` (tests/reference/smith_walk.py), NaN from
below the horizon, where it must not be used.
"""

import math

import numpy as np
import pytest
from numba import njit
from scipy import stats

from tests.reference import materials as ref
from tests.reference import smith_walk as ref_walk
from vcavity.microfacet import registry
from vcavity.rng import block_key

N_SAMPLES = 400_000
N_THETA, N_PHI, NODES = 16, 24, 12


@njit
def _draw_stream(kind, v, lam, params, n, seed):
    """``n`` normals from the registry's ``sample_visible_stream`` on one random stream."""
    state = block_key(np.uint64(seed), 0)
    out = np.empty((n, 3))
    for i in range(n):
        state, out[i, 0], out[i, 1], out[i, 2] = registry.sample_visible_stream(kind, state, v[0], v[1], v[2],
                                                                                 lam, params)
    return out


def _edges(alpha):
    """θ edges ``atan(α tan ψ)`` for ψ equally spaced on [0, π/2]: equal shares of a lobe of width α."""
    psi = np.linspace(0.0, 0.5 * math.pi, N_THETA + 1)
    return np.arctan(alpha * np.tan(psi[:-1])).tolist() + [0.5 * math.pi]


def _expected(material, v, theta_edges):
    """Cell integrals of ``<v, m>+ D(m) dω`` (Gauss-Legendre in θ and φ), normalised."""
    x, w = np.polynomial.legendre.leggauss(NODES)
    phi_edges = np.linspace(0.0, 2.0 * math.pi, N_PHI + 1)
    out = np.empty((N_THETA, N_PHI))
    for i in range(N_THETA):
        a, b = theta_edges[i], theta_edges[i + 1]
        th = 0.5 * (b - a) * x + 0.5 * (a + b)
        dth = np.full(NODES, 0.5 * (b - a))
        if i == N_THETA - 1:
            # the last ring reaches the horizon, where a heavy tail (Student-t with gamma < 2)
            # makes the integrand ~ (pi/2 - theta)^(2 gamma - 4): integrable but singular.
            # theta = pi/2 - s^10 makes it smooth in s for gamma >= 1.55
            s_lo, s_hi = 0.0, (0.5 * math.pi - a) ** 0.1
            s = 0.5 * (s_hi - s_lo) * x + 0.5 * (s_hi + s_lo)
            th = 0.5 * math.pi - s**10
            dth = 0.5 * (s_hi - s_lo) * 10.0 * s**9
        for j in range(N_PHI):
            c, d = phi_edges[j], phi_edges[j + 1]
            ph = 0.5 * (d - c) * x + 0.5 * (c + d)
            T, P = np.meshgrid(th, ph, indexing="ij")
            m = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
            f = np.maximum(m @ v, 0.0) * ref.ndf(material, m) * np.sin(T)
            out[i, j] = 0.5 * (d - c) * np.einsum("i,j,ij->", w * dth, w, f)
    return out / out.sum()


def _setup(name, roughness, theta_deg, phi_deg):
    """The reference material, the θ grid's roughness ``sqrt(ax ay)`` and the direction ``v``."""
    material = ref.parse_material({"distribution": name, "facet": "mirror", **roughness})
    # the θ grid follows the lobe's width (Phong's exponent n is like alpha sqrt(2/(n + 2)))
    ax = material.roughness.get("alpha_x", math.sqrt(2.0 / (material.roughness.get("exponent", 0.0) + 2.0)))
    ay = material.roughness.get("alpha_y", ax)
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    v = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    return material, math.sqrt(ax * ay), v


def _check(material, alpha, v, m):
    """Chi-square of the normals ``m`` against the cell integrals of ``<v, m>+ D(m)``."""
    assert np.allclose(np.linalg.norm(m, axis=1), 1.0, atol=1e-12)
    assert np.all(m[:, 2] > 0.0) and np.all(m @ v > -1e-12)  # only visible normals
    theta_edges = _edges(alpha)
    theta = np.arctan2(np.hypot(m[:, 0], m[:, 1]), m[:, 2])
    phi = np.mod(np.arctan2(m[:, 1], m[:, 0]), 2.0 * math.pi)
    observed, _, _ = np.histogram2d(theta, phi, bins=[theta_edges, np.linspace(0.0, 2.0 * math.pi, N_PHI + 1)])
    expected = N_SAMPLES * _expected(material, v, np.array(theta_edges))
    big = expected >= 10.0
    obs = np.append(observed[big], observed[~big].sum())
    exp = np.append(expected[big], expected[~big].sum())
    if exp[-1] == 0.0:
        obs, exp = obs[:-1], exp[:-1]
    chi2 = float(np.sum((obs - exp) ** 2 / np.where(exp > 0, exp, 1.0)))
    dof = obs.size - 1
    assert big.sum() > 30  # the grid resolves the lobe (from below, only steep normals are seen)
    assert stats.chi2.sf(chi2, dof) > 1e-4, f"chi2 {chi2:.1f} on {dof} dof"


# Beckmann's stream sampler, each piece of its mixture (physics.md sec. 14) with mu = cot of the
# stretched view: mu > sqrt(pi) (half-normal proposal), mu below it (triangle), near 0
# (grazing), seen from the normal, and from below the horizon (Gamma proposal) at
# m = -mu from 0.15 to 0.56 (larger m: tests/microfacet/test_beckmann_slope.py, where this
# grid resolves nothing).
STREAM_CASES = [
    ("beckmann", {"alpha": 0.3}, 45.0, 0.0),  # mu 3.3
    ("beckmann", {"alpha_x": 0.6, "alpha_y": 0.2}, 30.0, 37.0),  # mu 3.5, anisotropic
    ("beckmann", {"alpha_x": 0.6, "alpha_y": 0.2}, 80.0, 90.0),  # mu 0.88
    ("beckmann", {"alpha_x": 0.2, "alpha_y": 0.5}, 60.0, 37.0),  # mu 1.7
    ("beckmann", {"alpha": 0.6}, 60.0, 0.0),  # mu 0.96: fig. 7(b)'s first hit at 60 deg
    ("beckmann", {"alpha": 1.0}, 85.0, 0.0),  # mu 0.087
    ("beckmann", {"alpha": 0.7}, 0.0, 0.0),  # the normal
    ("beckmann", {"alpha": 1.2}, 100.0, 0.0),  # m 0.15
    ("beckmann", {"alpha_x": 0.8, "alpha_y": 0.4}, 120.0, 37.0),
    ("beckmann", {"alpha": 1.5}, 130.0, 0.0),  # m 0.56
]


@pytest.mark.parametrize("name, roughness, theta_deg, phi_deg", STREAM_CASES)
def test_stream_samplers_follow_their_density(name, roughness, theta_deg, phi_deg):
    material, alpha, v = _setup(name, roughness, theta_deg, phi_deg)
    kind, params = registry.params_from(name, material.roughness)
    lam = float(ref_walk.smith_lambda(material, v)) if v[2] > 0.0 else math.nan
    _check(material, alpha, v, _draw_stream(kind, v, lam, params, N_SAMPLES, 11))
