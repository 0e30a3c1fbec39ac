"""Microfacet distributions of normals and masking functions (physics.md sec. 2-3).

One module per distribution (:mod:`beckmann`, :mod:`ggx`, :mod:`phong`, :mod:`gaussian`,
...), all with the same interface, registered and dispatched in :mod:`.registry` (the
interface is documented there). Masking functions shared by all distributions are in
:mod:`.common`.
"""
