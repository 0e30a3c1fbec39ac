"""Directional albedo ``a(i) = ∫ f(i, o) cos θ_o dω_o`` of the analytic models by
quadrature, independent of the sensor (physics.md sec. 6-9).

- :func:`hemispherical_albedo`: any model with ``projected(i, o) = f cos θ_o``;
  Gauss-Legendre in ``cos θ_o`` times midpoints in ``φ_o``.
- :func:`specular_albedo`: the specular single-bounce term integrated over the half
  vector through the distribution's sampling map (``dω_o = 4 (i.h) dω_h``, W eq. 14),
  which resolves lobes of any width.
- :func:`single_bounce_albedo`: specular (as above) plus body (hemispherical rule).
- :func:`mean_cos_theta_m` and :func:`lambertian_normal_f1_albedo`: the exact f1
  albedo at ``eta = 1``, ``θ_i = 0`` (physics.md sec. 9): every path hits a facet,
  which re-emits with probability kd, and the 2D crossed-strings view factor from a
  facet of the groove to its opening is ``(sec + 2 - sec)/(2 sec) = cos θ_m``, so
  ``a_1 = kd E[cos θ_m]`` with ``m ~ D(m)(m.n)``.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit

from vcavity.analytic.single_bounce import SingleBounceModel, gauss_legendre_unit, squared_t_node
from vcavity.analytic.terms import VCAVITY, g2, smith_lambda
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions


def hemispherical_albedo(model, incident, n_mu: int = 96, n_phi: int = 192, lower: bool = False) -> float:
    """``∫ f(i, o) |cos θ_o| dω_o`` over the upper (or lower) hemisphere.

    Parameters
    ----------
    model : object with ``projected(incident, outgoing)`` returning ``f |cos θ_o|``
    incident : array_like (3,)
    n_mu, n_phi : int
        Gauss-Legendre nodes in ``|cos θ_o|`` and midpoints in ``φ_o``.
    lower : bool
        Integrate over ``o.n < 0`` (transmission) instead.

    Returns
    -------
    float
    """
    x, w = np.polynomial.legendre.leggauss(int(n_mu))
    mu = 0.5 * (x + 1.0)
    w_mu = 0.5 * w
    phi = (np.arange(n_phi) + 0.5) * (2.0 * math.pi / n_phi)
    sin_t = np.sqrt(1.0 - mu * mu)
    o = np.stack([
        (sin_t[:, None] * np.cos(phi)[None, :]).ravel(),
        (sin_t[:, None] * np.sin(phi)[None, :]).ravel(),
        np.broadcast_to(-mu[:, None] if lower else mu[:, None], (mu.size, phi.size)).ravel(),
    ], axis=1)
    values = model.projected(np.asarray(incident, dtype=np.float64), o).reshape(mu.size, phi.size)
    return float(np.sum(values * w_mu[:, None]) * (2.0 * math.pi / n_phi))


@njit(cache=True)
def _specular_albedo(incident, kind, params, facet_kind, facet_data, masking, walter_fit, t_nodes, t_weights,
                     n_u2):
    """``∫ F(i.h) G2(i, o, h) (i.h) / ((i.n)(h.n)) p(h) dω_h`` with ``o = 2 (i.h) h - i``.

    W eq. 14 Jacobian: ``f_s cos θ_o dω_o = F D G2 (i.h) / (i.n) dω_h``; ``D dω_h =
    p(h) dω_h / (h.n)`` with ``p`` the sampling pdf (physics.md sec. 2).
    """
    ix, iy, iz = incident[0], incident[1], incident[2]
    lambda_i = 0.0 if masking == VCAVITY else smith_lambda(kind, ix, iy, iz, params, walter_fit)
    total = 0.0
    for a in range(t_nodes.shape[0]):
        u1, jacobian = squared_t_node(t_nodes[a], t_weights[a], n_u2)
        for b in range(n_u2):
            hx, hy, hz = distributions.sample_normal(kind, u1, (b + 0.5) / n_u2, params)
            ih = ix * hx + iy * hy + iz * hz
            if ih <= 0.0 or hz <= 0.0:
                continue
            ox, oy, oz = 2.0 * ih * hx - ix, 2.0 * ih * hy - iy, 2.0 * ih * hz - iz
            if oz <= 0.0:
                continue
            lambda_o = 0.0 if masking == VCAVITY else smith_lambda(kind, ox, oy, oz, params, walter_fit)
            g = g2(masking, ix, iy, iz, ox, oy, oz, hx, hy, hz, lambda_i, lambda_o)
            total += jacobian * facets.reflectance(facet_kind, ih, facet_data) * g * ih / (iz * hz)
    return total


def specular_albedo(model: SingleBounceModel, incident, n_nodes: int = 256) -> float:
    """Albedo of the specular single-bounce term, integrated over the half vector.

    ``n_nodes`` Gauss-Legendre nodes in ``t`` (``u1 = 1 - (1-t)^2``) times ``2 n_nodes``
    midpoints in ``u2`` (physics.md sec. 9). Accuracy: about 1e-7 relative at the
    default (kinks of G2 and the horizon cut limit it to ``O(n_nodes^-2)``).
    """
    if not model.has_specular:
        return 0.0
    t_nodes, t_weights = gauss_legendre_unit(int(n_nodes))
    return float(_specular_albedo(np.ascontiguousarray(incident, dtype=np.float64), model.kind,
                                  model.params, model.facet_kind, model.facet_data, model.masking_code,
                                  model.lambda_fit, t_nodes, t_weights, 2 * int(n_nodes)))


class _BodyOnly:
    def __init__(self, model):
        self.model = model

    def projected(self, incident, outgoing):
        return self.model.body_projected(incident, outgoing)


def single_bounce_albedo(model: SingleBounceModel, incident, n_nodes: int = 256,
                         n_mu: int = 64, n_phi: int = 128) -> tuple[float, float]:
    """``(specular, body)`` albedos of a :class:`SingleBounceModel` for one direction.

    Specular by :func:`specular_albedo`, body by :func:`hemispherical_albedo` (the body
    is smooth in ``o``; its own ``n_nodes`` control applies inside).
    """
    specular = specular_albedo(model, incident, n_nodes)
    body = hemispherical_albedo(_BodyOnly(model), incident, n_mu, n_phi) if model.body_factor else 0.0
    return specular, body


def mean_cos_theta_m(model: SingleBounceModel, n_nodes: int = 512) -> float:
    """``E[cos θ_m] = ∫ D(m) (m.n)^2 dω_m`` over the sampling map (physics.md sec. 2).

    Gauss-Legendre in ``t`` with ``u1 = 1 - (1-t)^2`` and midpoints in ``u2``; the
    integrand ``m.n`` is smooth, so this converges to round-off (1e-13 at 512).
    """
    t_nodes, t_weights = gauss_legendre_unit(int(n_nodes))
    return float(_mean_cos(model.kind, model.params, t_nodes, t_weights, 2 * int(n_nodes)))


@njit(cache=True)
def _mean_cos(kind, params, t_nodes, t_weights, n_u2):
    total = 0.0
    for a in range(t_nodes.shape[0]):
        t = t_nodes[a]
        u1 = 1.0 - (1.0 - t) * (1.0 - t)
        for b in range(n_u2):
            mz = distributions.sample_normal(kind, u1, (b + 0.5) / n_u2, params)[2]
            total += 2.0 * (1.0 - t) * t_weights[a] / n_u2 * mz
    return total


def lambertian_normal_f1_albedo(model: SingleBounceModel) -> float:
    """Exact f1 albedo at ``θ_i = 0`` for Lambertian facets (``eta = 1``): ``kd E[cos θ_m]``.

    Lambertian facets are facets without a specular part whose body factor is
    ``K = kd / pi`` (the IL facet at ``eta = 1``), so ``kd = pi K``.

    Derivation in the module docstring (2D crossed-strings view factor per groove,
    physics.md sec. 9).

    Raises
    ------
    ValueError
        If the facets are not Lambertian (a specular part, or no body).
    """
    if model.has_specular or model.body_factor == 0.0:
        raise ValueError("the closed form holds for Lambertian facets (eta = 1) only")
    return math.pi * model.body_factor * mean_cos_theta_m(model)
