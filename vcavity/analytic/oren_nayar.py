"""Oren-Nayar (1994) rough diffuse BRDF and the flat Lambert limit (physics.md sec. 7).

The full model for V-cavities with Lambertian facets of albedo ``rho`` and the Gaussian
distribution of slope angles of width ``sigma`` (IL eq. 13, the "gaussian" distribution
here), as restated in physics.md sec. 7::

    f = (rho/pi) [C1 + cos(dphi) C2 tan(beta) + (1 - |cos dphi|) C3 tan((alpha+beta)/2)]
        + 0.17 (rho^2/pi) sigma^2/(sigma^2 + 0.13) (1 - cos(dphi) (2 beta/pi)^2)

with ``alpha = max(theta_i, theta_o)``, ``beta = min(theta_i, theta_o)``,
``C1 = 1 - 0.5 sigma^2/(sigma^2 + 0.33)``,
``C2 = 0.45 sigma^2/(sigma^2 + 0.09) sin(alpha)`` if ``cos dphi >= 0`` else
``0.45 sigma^2/(sigma^2 + 0.09) (sin(alpha) - (2 beta/pi)^3)``,
``C3 = 0.125 sigma^2/(sigma^2 + 0.09) (4 alpha beta/pi^2)^2``. The bracket fits single
scattering (f1), the 0.17 term two-bounce inter-reflection (f2): a fit, a few percent
from the exact V-cavity values (docs/validation.md gives the measured difference).
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.material import Material


def _angles(incident, outgoing):
    """theta_i (scalar), theta_o (M,), cos(phi_o - phi_i) (M,) (1 where undefined)."""
    i = np.asarray(incident, dtype=np.float64).reshape(3)
    o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
    theta_i = math.acos(min(1.0, max(-1.0, i[2])))
    theta_o = np.arccos(np.clip(o[:, 2], -1.0, 1.0))
    r_i = math.hypot(i[0], i[1])
    r_o = np.hypot(o[:, 0], o[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_dphi = (i[0] * o[:, 0] + i[1] * o[:, 1]) / (r_i * r_o)
    cos_dphi = np.where((r_i > 0.0) & (r_o > 0.0), np.clip(cos_dphi, -1.0, 1.0), 1.0)
    return theta_i, theta_o, cos_dphi, o


def oren_nayar_brdf(incident, outgoing, sigma: float, rho: float, interreflection: bool = True) -> np.ndarray:
    """Oren-Nayar BRDF in 1/sr (physics.md sec. 7; formula in the module docstring).

    Parameters
    ----------
    incident : array_like (3,)
        Unit direction toward the light.
    outgoing : array_like (M, 3)
        Unit directions toward the viewer.
    sigma : float
        Width of the Gaussian slope-angle distribution, radians.
    rho : float
        Albedo of the Lambertian facets (``kd``).
    interreflection : bool
        Include the 0.17 two-bounce term (full model); False gives the single-scattering
        bracket alone.

    Returns
    -------
    ndarray (M,)
        0 where ``o.n <= 0``.
    """
    theta_i, theta_o, cos_dphi, o = _angles(incident, outgoing)
    s2 = sigma * sigma
    alpha = np.maximum(theta_i, theta_o)
    beta = np.minimum(theta_i, theta_o)
    c1 = 1.0 - 0.5 * s2 / (s2 + 0.33)
    two_beta_over_pi = 2.0 * beta / math.pi
    c2 = 0.45 * s2 / (s2 + 0.09) * np.where(cos_dphi >= 0.0, np.sin(alpha),
                                            np.sin(alpha) - two_beta_over_pi**3)
    c3 = 0.125 * s2 / (s2 + 0.09) * (4.0 * alpha * beta / math.pi**2) ** 2
    single = (rho / math.pi) * (c1 + cos_dphi * c2 * np.tan(beta)
                                + (1.0 - np.abs(cos_dphi)) * c3 * np.tan(0.5 * (alpha + beta)))
    value = single
    if interreflection:
        value = single + 0.17 * (rho * rho / math.pi) * s2 / (s2 + 0.13) * (
            1.0 - cos_dphi * two_beta_over_pi**2)
    upper = (o[:, 2] > 0.0) & (float(np.asarray(incident).reshape(3)[2]) > 0.0)
    return np.where(upper, value, 0.0)


class OrenNayarModel:
    """Oren-Nayar model of a material (Gaussian distribution, Lambertian facets).

    Parameters
    ----------
    material : vcavity.material.Material
        Must have the ``gaussian`` distribution (``sigma``) and Lambertian facets: a facet
        without a specular part whose body factor is ``K = rho / pi`` (the interfaced
        Lambertian facet with ``eta = 1``, ``rho = kd``).
    interreflection : bool
        Full model (f1 + f2 estimate) or the single-scattering bracket.

    Raises
    ------
    ModelNotApplicable
        For any other material.
    """

    def __init__(self, material: Material, interreflection: bool = True):
        from vcavity.analytic.single_bounce import ModelNotApplicable
        from vcavity.facet import registry as facets

        if material.distribution != "gaussian":
            raise ModelNotApplicable(
                f"oren-nayar needs the gaussian distribution, the table has {material.distribution!r}")
        body = facets.body_factor(material.facet, material.facet_params)
        if facets.has_specular(material.facet, material.facet_params) or body == 0.0:
            raise ModelNotApplicable("oren-nayar needs Lambertian facets (interfaced_lambertian with eta = 1)")
        self.material = material
        self.sigma = float(material.distribution_params["sigma"])
        self.rho = math.pi * body
        self.interreflection = bool(interreflection)

    def brdf(self, incident, outgoing) -> np.ndarray:
        """BRDF in 1/sr, shape (M,)."""
        return oren_nayar_brdf(incident, outgoing, self.sigma, self.rho, self.interreflection)

    def projected(self, incident, outgoing) -> np.ndarray:
        """``f cos θ_o``, shape (M,)."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        return self.brdf(incident, o) * np.maximum(o[:, 2], 0.0)


class LambertModel:
    """Lambertian BRDF ``kd/π`` (the flat, ``eta = 1`` limit of physics.md sec. 7)."""

    def __init__(self, kd: float):
        self.kd = float(kd)

    def brdf(self, incident, outgoing) -> np.ndarray:
        """``kd/π`` above the surface, 0 below."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        return np.where(o[:, 2] > 0.0, self.kd / math.pi, 0.0)

    def projected(self, incident, outgoing) -> np.ndarray:
        """``(kd/π) cos θ_o``."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        return self.kd / math.pi * np.maximum(o[:, 2], 0.0)
