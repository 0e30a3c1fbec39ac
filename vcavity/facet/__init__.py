"""Facet models: what happens when light hits one microfacet (physics.md sec. 4).

One module per facet model (:mod:`.interfaced_lambertian`, :mod:`.mirror`), registered
and dispatched in :mod:`.registry` (the interface is documented there);
:mod:`.fresnel` holds the dielectric Fresnel terms and diffuse reflectances of an
interface (W eq. 22, IL eq. 7, 10) and :mod:`.common` what every facet event shares.
"""
