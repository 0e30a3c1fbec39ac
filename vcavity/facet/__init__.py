"""Facet models: what happens when light hits one microfacet (physics.md sec. 4).

``fresnel``: dielectric Fresnel terms and diffuse interface reflectances (W eq. 22,
IL eq. 7, 10). ``interfaced_lambert``: the interfaced Lambertian facet (IL eq. 4-8).
``mirror``: the perfect mirror facet.
"""

from vcavity.facet import interfaced_lambert, mirror
from vcavity.facet.fresnel import (
    emergence_probability,
    fresnel_dielectric,
    fresnel_dielectric_array,
    fresnel_transmittance,
    fresnel_transmittance_array,
    one_minus_r_i,
    r_e,
    r_i,
)

__all__ = [
    "emergence_probability",
    "fresnel_dielectric",
    "fresnel_dielectric_array",
    "fresnel_transmittance",
    "fresnel_transmittance_array",
    "interfaced_lambert",
    "mirror",
    "one_minus_r_i",
    "r_e",
    "r_i",
]
