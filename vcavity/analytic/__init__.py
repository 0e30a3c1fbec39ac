"""Analytic BRDF models for validating the simulator (physics.md sec. 7).

- :class:`SingleBounceModel`: specular + interfaced-Lambertian body single-bounce BRDF
  with V-cavity (= expectation of the simulated f1), Smith separable or height-correlated
  G2 (:mod:`vcavity.analytic.single_bounce`);
- :class:`OrenNayarModel`, :class:`LambertModel` (:mod:`vcavity.analytic.oren_nayar`);
- :class:`WalterDielectric`: rough dielectric BRDF/BTDF, W eq. 20-21
  (:mod:`vcavity.analytic.walter`);
- cell averages as a table stores them (:mod:`vcavity.analytic.cells`), directional
  albedos and exact checks (:mod:`vcavity.analytic.albedo`), statistics helpers
  (:mod:`vcavity.analytic.statistics`).
"""

from vcavity.analytic.albedo import (
    hemispherical_albedo,
    lambertian_normal_f1_albedo,
    mean_cos_theta_m,
    single_bounce_albedo,
    specular_albedo,
)
from vcavity.analytic.cells import cell_average, cell_integrals, expected_counts
from vcavity.analytic.oren_nayar import LambertModel, OrenNayarModel, oren_nayar_brdf
from vcavity.analytic.single_bounce import ModelNotApplicable, SingleBounceModel, flat_body_brdf
from vcavity.analytic.walter import WalterDielectric

__all__ = [
    "SingleBounceModel", "ModelNotApplicable", "flat_body_brdf",
    "OrenNayarModel", "LambertModel", "oren_nayar_brdf", "WalterDielectric",
    "cell_integrals", "cell_average", "expected_counts",
    "hemispherical_albedo", "specular_albedo", "single_bounce_albedo", "mean_cos_theta_m",
    "lambertian_normal_f1_albedo",
]
