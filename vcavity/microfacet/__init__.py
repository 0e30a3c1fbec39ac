"""Microfacet distributions of normals and masking functions (physics.md sec. 2-3).

Every distribution module (:mod:`beckmann`, :mod:`ggx`, :mod:`phong`,
:mod:`gaussian`) has the same interface; ``params`` is a 1-D float64 array
built by the module's ``make_params`` (layout in the module docstring):

- ``NAME`` (str), ``KIND`` (int), ``HAS_EXACT_SMITH`` (bool)
- ``make_params(...) -> ndarray`` (plain Python)
- ``sample(u1, u2, params) -> (tan_theta_m, cos_phi_m, sin_phi_m)``: pdf ``D(m)(m.n)``
- ``sample_normal(u1, u2, params) -> (mx, my, mz)``
- ``D(mx, my, mz, params)``, ``pdf(mx, my, mz, params) = D * mz``
- ``smith_lambda(vx, vy, vz, params)``
- ``sample_normal_many(u1, u2, params) -> (N, 3)``, ``D_many(m, params)``,
  ``pdf_many(m, params)``, ``smith_lambda_many(v, params)`` over ``(N, 3)`` rows

Masking functions shared by all distributions are in :mod:`common`.
"""

from vcavity.microfacet import beckmann, common, gaussian, ggx, phong

DISTRIBUTIONS = {
    beckmann.NAME: beckmann,
    ggx.NAME: ggx,
    phong.NAME: phong,
    gaussian.NAME: gaussian,
}

BY_KIND = sorted(DISTRIBUTIONS.values(), key=lambda module: module.KIND)
assert [module.KIND for module in BY_KIND] == list(range(len(BY_KIND)))


def get(name):
    """Return the distribution module called ``name``.

    Parameters
    ----------
    name : str
        One of ``"beckmann"``, ``"ggx"``, ``"phong"``, ``"gaussian"`` (case-insensitive).

    Returns
    -------
    module
        The distribution module.

    Raises
    ------
    KeyError
        For an unknown name (the message lists the known ones).
    """
    key = str(name).lower()
    if key not in DISTRIBUTIONS:
        raise KeyError(f"unknown microfacet distribution {name!r}; known: {sorted(DISTRIBUTIONS)}")
    return DISTRIBUTIONS[key]


__all__ = ["DISTRIBUTIONS", "BY_KIND", "get", "beckmann", "ggx", "phong", "gaussian", "common"]
