"""Materials from first principles, in plain NumPy/SciPy (no vcavity physics imported).

Everything here is written from the formulas of docs/physics.md (sec. 2, 3, 4, 10) and
the textbooks they cite, and parameterised *by hand* from a config-style material dict,
so that the package's parameter packing (``params_from``), its samplers, its Fresnel code
and its masking are all under test when the simulator is judged against this module:

- :func:`parse_material`: the ``[material]`` table of a run config -> :class:`Material`
  (``alpha`` or ``alpha_x`` (along +x) and ``alpha_y`` (along +y); ``exponent``;
  ``sigma``; ``gamma``; ``facet``, ``kd``, ``eta`` with the documented defaults
  ``distribution = "beckmann"``, ``facet = "interfaced_lambertian"``, ``eta = 1.5``);
- :func:`ndf`: closed-form ``D(m)`` (1/sr) of beckmann, ggx, phong, gaussian (its
  constant by ``scipy.integrate.quad``) and student_t;
- :func:`fresnel_amplitudes`, :func:`fresnel_reflectance`, :func:`fresnel_transmittance`:
  the exact unpolarised dielectric Fresnel factors from Snell's law and the textbook
  amplitude coefficients ``r_s, r_p, t_s, t_p`` (Born & Wolf sec. 1.5.2);
- :func:`diffuse_reflectance_outside` (``r_e = ∫ F(cos t) sin 2t dt``, by quadrature),
  :func:`diffuse_reflectance_inside` (``r_i = 1 - (1 - r_e)/eta^2``),
  :func:`body_constant` (``kd / (pi eta^2 (1 - kd r_i))``, IL eq. 8);
- :func:`g1_vcavity`, :func:`g2_vcavity`: V-cavity masking (H eq. 49; IL eq. 14);
- :func:`normal_quadrature`: a deterministic rule for ``∫ g(m) D(m)(m.n) dω_m``:
  composite Gauss-Legendre in ``theta_m`` on panels graded to the distribution's angular
  scale, midpoints in ``phi_m``, weights from the closed-form ``D`` (never a sampler).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy import integrate

from tests.reference import conductor_fresnel

DISTRIBUTIONS = ("beckmann", "ggx", "phong", "gaussian", "student_t")
FACETS = ("interfaced_lambertian", "mirror")
_DEFAULT_ETA = 1.5  # vcavity/config.py docstring and facet parameter default


@dataclass(frozen=True)
class Material:
    """A reference material.

    ``roughness`` holds the distribution's parameters by name: ``alpha_x``, ``alpha_y``
    (beckmann, ggx, student_t; plus ``gamma`` for student_t), ``exponent`` (phong),
    ``sigma`` (gaussian, radians). ``facet`` is ``"mirror"``,
    ``"interfaced_lambertian"`` (then ``kd`` and ``eta`` are set) or ``"conductor"``
    (``eta`` and ``k``: the complex index ``eta + i k``; no body).
    """

    distribution: str
    roughness: dict = field(default_factory=dict)
    facet: str = "interfaced_lambertian"
    kd: float = 0.0
    eta: float = 1.0
    k: float = 0.0

    @property
    def is_mirror(self) -> bool:
        return self.facet == "mirror"

    @property
    def has_body(self) -> bool:
        return (not self.is_mirror) and self.kd > 0.0

    @property
    def is_conductor(self) -> bool:
        return self.facet == "conductor"

    @property
    def has_interface(self) -> bool:
        """True when the facet reflects specularly (mirror, conductor, or a dielectric eta > 1)."""
        return self.is_mirror or self.is_conductor or self.eta > 1.0

    def key(self):
        return (self.distribution, tuple(sorted(self.roughness.items())), self.facet, self.kd, self.eta, self.k)


def parse_material(raw: dict) -> Material:
    """Config-style ``[material]`` dict -> :class:`Material`, by hand (see module docstring)."""
    raw = dict(raw)
    dist = raw.pop("distribution", "beckmann")
    facet = raw.pop("facet", "interfaced_lambertian")
    if dist not in DISTRIBUTIONS:
        raise ValueError(f"unknown distribution {dist!r}")
    rough = {}
    if dist in ("beckmann", "ggx", "student_t"):
        if "alpha" in raw:
            rough["alpha_x"] = rough["alpha_y"] = float(raw.pop("alpha"))
        else:
            rough["alpha_x"] = float(raw.pop("alpha_x"))  # along +x
            rough["alpha_y"] = float(raw.pop("alpha_y"))  # along +y
        if dist == "student_t":
            rough["gamma"] = float(raw.pop("gamma"))
    elif dist == "phong":
        rough["exponent"] = float(raw.pop("exponent"))
    elif dist == "gaussian":
        rough["sigma"] = float(raw.pop("sigma"))
    k = 0.0
    if facet == "mirror":
        kd, eta = 0.0, 1.0
    elif facet == "interfaced_lambertian":
        kd = float(raw.pop("kd"))
        eta = float(raw.pop("eta", _DEFAULT_ETA))
    elif facet == "conductor":  # defaults: gold at 548.6 nm (Johnson & Christy 1972), as documented
        kd, eta, k = 0.0, float(raw.pop("eta", 0.43)), float(raw.pop("k", 2.455))
    else:
        raise ValueError(f"unknown facet {facet!r}")
    if raw:
        raise ValueError(f"unused material keys: {sorted(raw)}")
    return Material(dist, rough, facet, kd, eta, k)


# ------------------------------------------------------------------ distributions


@lru_cache(maxsize=None)
def gaussian_constant(sigma: float) -> float:
    """``C`` of the Gaussian in theta_m: ``1/C = 2 pi ∫_0^{pi/2} exp(-θ²/(2σ²)) sin θ dθ`` (quad)."""
    f = lambda t: math.exp(-0.5 * (t / sigma) ** 2) * math.sin(t)
    points = [p for p in (0.5 * sigma, sigma, 2 * sigma, 4 * sigma, 8 * sigma) if p < 0.5 * math.pi]
    value, _ = integrate.quad(f, 0.0, 0.5 * math.pi, points=points or None, epsabs=0.0, epsrel=1e-13,
                              limit=400)
    return 1.0 / (2.0 * math.pi * value)


def ndf(material: Material, m) -> np.ndarray:
    """``D(m)`` in 1/sr for unit normals ``m`` of shape (..., 3); 0 where ``m_z <= 0``.

    beckmann (H eq. 82): ``exp(-tan²θ (cos²φ/αx² + sin²φ/αy²)) / (π αx αy cos⁴θ)``;
    ggx (H eq. 85): ``1 / (π αx αy cos⁴θ (1 + tan²θ (cos²φ/αx² + sin²φ/αy²))²)``;
    phong (W eq. 30): ``(n + 2)/(2π) cos^n θ``; gaussian (IL eq. 13):
    ``C exp(-θ²/(2σ²)) / cos θ``; student_t (physics.md sec. 10):
    ``(γ-1)^γ / (π αx αy cos⁴θ (γ - 1 + tan²θ (...))^γ)``. With ``m = (sinθ cosφ,
    sinθ sinφ, cosθ)``: ``tan²θ cos²φ = m_x²/m_z²`` and ``tan²θ sin²φ = m_y²/m_z²``.
    """
    m = np.asarray(m, dtype=np.float64)
    mx, my, mz = m[..., 0], m[..., 1], m[..., 2]
    up = mz > 0.0
    mzs = np.where(up, mz, 1.0)
    r = material.roughness
    name = material.distribution
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        if name in ("beckmann", "ggx", "student_t"):
            ax, ay = r["alpha_x"], r["alpha_y"]
            t2 = (mx * mx / (ax * ax) + my * my / (ay * ay)) / (mzs * mzs)
            cos4 = mzs ** 4
            if name == "beckmann":
                val = np.exp(-t2) / (math.pi * ax * ay * cos4)
            elif name == "ggx":
                val = 1.0 / (math.pi * ax * ay * cos4 * (1.0 + t2) ** 2)
            else:
                g = r["gamma"]
                # (γ-1)^γ/(γ-1+t²)^γ = (1 + t²/(γ-1))^(-γ)
                val = np.exp(-g * np.log1p(t2 / (g - 1.0))) / (math.pi * ax * ay * cos4)
        elif name == "phong":
            n = r["exponent"]
            val = (n + 2.0) / (2.0 * math.pi) * mzs ** n
        elif name == "gaussian":
            s = r["sigma"]
            theta = np.arctan2(np.hypot(mx, my), mzs)
            val = gaussian_constant(s) * np.exp(-0.5 * (theta / s) ** 2) / mzs
        else:
            raise ValueError(name)
    val = np.where(np.isfinite(val), val, 0.0)
    return np.where(up, val, 0.0)


def angular_scale(material: Material) -> float:
    """A width in radians of ``theta_m`` on which ``D`` varies (the narrowest direction)."""
    r = material.roughness
    name = material.distribution
    if name in ("beckmann", "ggx", "student_t"):
        return math.atan(min(r["alpha_x"], r["alpha_y"]))
    if name == "phong":
        return math.atan(math.sqrt(2.0 / (r["exponent"] + 2.0)))
    return min(r["sigma"], 1.0)


def theta_panels(scale: float) -> np.ndarray:
    """Panel edges on ``[0, π/2]`` graded to ``scale``: 0, s/4, s/2, s, 1.5 s, 2 s, 3 s, ..."""
    factors = [0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0, 48.0, 64.0,
               96.0, 128.0, 192.0, 256.0, 384.0, 512.0]
    edges = [0.0] + [scale * f for f in factors if scale * f < 0.5 * math.pi - 1e-3]
    # finer panels near the horizon (GGX tails, Gaussian), at least 3 panels above 1 rad
    top = edges[-1]
    for extra in np.linspace(top, 0.5 * math.pi, 4)[1:]:
        edges.append(float(extra))
    return np.unique(np.array(edges))


def normal_quadrature(material: Material, n_gauss: int = 12, n_phi: int = 64, phase: float = 0.0,
                      panels=None):
    """Nodes ``m`` (M, 3) and weights ``w`` (M,) with ``Σ w g(m) ≈ ∫ g(m) D(m)(m.n) dω_m``.

    ``dω_m = sin θ dθ dφ``: composite ``n_gauss``-point Gauss-Legendre in ``θ`` on the
    panels of :func:`theta_panels`, ``n_phi`` midpoints in ``φ`` (shifted by ``phase``
    times the spacing), weights ``D(m) cos θ sin θ Δθ Δφ`` from :func:`ndf`.

    Returns ``m, w, theta, phi`` (the latter two per node).
    """
    edges = theta_panels(angular_scale(material)) if panels is None else np.asarray(panels)
    x, wx = np.polynomial.legendre.leggauss(n_gauss)
    lo, hi = edges[:-1, None], edges[1:, None]
    theta = (0.5 * (hi + lo) + 0.5 * (hi - lo) * x).ravel()
    w_theta = (0.5 * (hi - lo) * wx).ravel()
    phi = (np.arange(n_phi) + 0.5 + phase) * (2.0 * math.pi / n_phi)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    st = np.sin(tt)
    m = np.stack([st * np.cos(pp), st * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    w = (ndf(material, m).reshape(tt.shape) * np.cos(tt) * st * w_theta[:, None]
         * (2.0 * math.pi / n_phi)).ravel()
    return m, w, tt.ravel(), pp.ravel()


# ------------------------------------------------------------------ Fresnel (Snell + amplitudes)


def fresnel_amplitudes(cos_i, eta: float):
    """Textbook amplitude coefficients for light from the outside (index 1) into index ``eta``.

    Snell: ``sin t = sin i / eta``; ``r_s = (cos i - eta cos t)/(cos i + eta cos t)``,
    ``r_p = (eta cos i - cos t)/(eta cos i + cos t)``, ``t_s = 2 cos i/(cos i + eta cos t)``,
    ``t_p = 2 cos i/(eta cos i + cos t)``. Returns ``r_s, r_p, t_s, t_p, cos_t``.
    """
    c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    sin_t2 = (1.0 - c * c) / (eta * eta)
    ct = np.sqrt(np.maximum(0.0, 1.0 - sin_t2))
    r_s = (c - eta * ct) / (c + eta * ct)
    r_p = (eta * c - ct) / (eta * c + ct)
    t_s = 2.0 * c / (c + eta * ct)
    t_p = 2.0 * c / (eta * c + ct)
    return r_s, r_p, t_s, t_p, ct


def fresnel_reflectance(cos_i, eta: float) -> np.ndarray:
    """Unpolarised ``F = (r_s² + r_p²)/2``; 0 for ``eta == 1``, 1 at grazing incidence."""
    if eta == 1.0:
        return np.zeros_like(np.asarray(cos_i, dtype=np.float64))
    r_s, r_p, _, _, _ = fresnel_amplitudes(cos_i, eta)
    return 0.5 * (r_s * r_s + r_p * r_p)


def fresnel_transmittance(cos_i, eta: float) -> np.ndarray:
    """``T = 1 - F`` (the definition the package's walk must reproduce)."""
    return 1.0 - fresnel_reflectance(cos_i, eta)


def fresnel_transmittance_from_amplitudes(cos_i, eta: float) -> np.ndarray:
    """``T = (eta cos t / cos i)(t_s² + t_p²)/2`` (power transmittance; a check of 1 - F)."""
    c = np.asarray(cos_i, dtype=np.float64)
    _, _, t_s, t_p, ct = fresnel_amplitudes(c, eta)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = 0.5 * eta * ct / c * (t_s * t_s + t_p * t_p)
    return np.where(c > 0.0, out, 0.0)


@lru_cache(maxsize=None)
def diffuse_reflectance_outside(eta: float) -> float:
    """``r_e = ∫_0^{π/2} F(cos t) sin 2t dt`` by ``scipy.integrate.quad``."""
    if eta == 1.0:
        return 0.0
    f = lambda t: float(fresnel_reflectance(math.cos(t), eta)) * math.sin(2.0 * t)
    # F varies fast near grazing incidence (cos t ~ sqrt(eta² - 1) for eta near 1)
    scale = math.sqrt((eta - 1.0) * (eta + 1.0))
    points = sorted({math.acos(min(1.0, s)) for s in (0.3 * scale, scale, 3 * scale, 0.3 / eta, 1 / eta)
                     if 0.0 < s < 1.0})
    value, _ = integrate.quad(f, 0.0, 0.5 * math.pi, points=points or None, epsabs=1e-15, epsrel=1e-13,
                              limit=500)
    return value


def diffuse_reflectance_inside(eta: float) -> float:
    """``r_i = 1 - (1 - r_e)/eta²`` (IL, after eq. 9)."""
    return 1.0 - (1.0 - diffuse_reflectance_outside(eta)) / (eta * eta)


def body_constant(kd: float, eta: float) -> float:
    """IL eq. 8 constant ``kd / (pi eta² (1 - kd r_i))``."""
    if kd == 0.0:
        return 0.0
    return kd / (math.pi * eta * eta * (1.0 - kd * diffuse_reflectance_inside(eta)))


def emergence_probability(kd: float, eta: float) -> float:
    """``a = kd (1 - r_i)/(1 - kd r_i)``: light entering the body that leaves it again."""
    ri = diffuse_reflectance_inside(eta)
    return kd * (1.0 - ri) / (1.0 - kd * ri)


def facet_reflectance(material: Material, cos_i) -> np.ndarray:
    """Specular reflectance of the facet: 1 for a mirror, the complex-index Fresnel ``F`` of
    tests/reference/conductor_fresnel.py for a conductor, the dielectric ``F`` otherwise."""
    if material.is_mirror:
        return np.ones_like(np.asarray(cos_i, dtype=np.float64))
    if material.is_conductor:
        return conductor_fresnel.fresnel_conductor(np.abs(np.asarray(cos_i, dtype=np.float64)), material.eta,
                                                   material.k)
    return fresnel_reflectance(cos_i, material.eta)


# ------------------------------------------------------------------ V-cavity masking


def g1_vcavity(v, m) -> np.ndarray:
    """``χ+(v.m) min(1, 2 (m.n)(v.n)/(v.m))``, clamped at 0 (H eq. 49, IL eq. 14); broadcasts."""
    v = np.asarray(v, dtype=np.float64)
    m = np.asarray(m, dtype=np.float64)
    vm = np.sum(v * m, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.minimum(1.0, 2.0 * m[..., 2] * v[..., 2] / vm)
    return np.where(vm > 0.0, np.maximum(g, 0.0), 0.0)


def g2_vcavity(i, o, m) -> np.ndarray:
    """``min(G1_V(i, m), G1_V(o, m))`` (IL eq. 14)."""
    return np.minimum(g1_vcavity(i, m), g1_vcavity(o, m))


def direction(theta: float, phi: float) -> np.ndarray:
    """``(sin θ cos φ, sin θ sin φ, cos θ)`` (physics.md sec. 1)."""
    s = math.sin(theta)
    return np.array([s * math.cos(phi), s * math.sin(phi), math.cos(theta)])
