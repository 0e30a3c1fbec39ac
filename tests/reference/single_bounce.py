"""Exact expectation of the simulated ``f1`` per sensor cell, in plain NumPy.

With V-cavity masking the single-bounce model is the exact mean of the walk's order-1
exits (physics.md sec. 3, 5, 7). Per cell ``c`` of an ``N x N`` sensor this module gives

    P_c = ∫_c f1(i, o) cos θ_o dω_o            (probability that a path is an f1 exit in c)

as the sum of

- the specular term, ``f_s cos θ_o = F(i.h) D(h) G2(i, o, h) / (4 i.n)`` with
  ``h = normalize(i + o)`` (W eq. 20, the ``cos θ_o`` cancels): integrated over ``o``
  in each cell with the per-cell rule of :mod:`tests.reference.sensor`, ``n_sub``
  subdivisions chosen so that the lobe is resolved;
- the IL body term (IL eq. 12): ``f_b cos θ_o = (K / i.n) ∫ (i.m)⁺ (o.m)⁺ T(i.m) T(o.m)
  D(m) G2(i, o, m) dω_m``, ``K = kd / (π η² (1 - kd r_i))``, integrated over normals with
  :func:`tests.reference.materials.normal_quadrature` (composite Gauss-Legendre in
  ``θ_m``, midpoints in ``φ_m``, weights from the closed-form ``D``; no sampler) and over
  ``o`` with the per-cell rule.

Facets: mirror (``F = 1``, no body); IL with ``kd = 0`` (dielectric, specular only),
``η = 1`` (Lambertian, ``F = 0``, body only) and the full IL facet.

Accuracy of the defaults (measured in tests/validation/test_reference_checks.py, by
refinement and against the sensor-free integrals :func:`specular_albedo_half_vector`,
:func:`body_albedo_direct` and the crossed-strings value ``kd E[cos θ_m]``): see
:data:`ACCURACY`. The specular rule uses 8 x 8 Gauss points on at least 8 x 8
sub-squares per cell (more for narrow lobes); the body rule 4 x 4 points per cell
(8 x 8 in the ring of horizon cells) and 12-point panels x 48+ azimuths over normals.
"""

from __future__ import annotations

import math

import numpy as np

from tests.reference import materials as mat
from tests.reference import sensor as sen

#: Measured accuracy of the default settings, relative: worst cell (cells above 1e-3 of
#: the largest) and albedo. Body: 2.8e-3 / 5e-5 in the worst case met (a horizon cell,
#: GGX 0.5, eta 2.5, theta_i = 80 deg), otherwise <= 3e-4 / 5e-6. Exact at eta = 1,
#: theta_i = 0 (crossed strings, 1e-13).
ACCURACY = {"specular_cell": 2e-5, "specular_albedo": 1e-6, "body_cell": 3e-4, "body_albedo": 5e-6,
            "body_cell_grazing": 3e-3, "body_albedo_grazing": 5e-5}


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def specular_cells(material: mat.Material, incident, n: int, n_gauss: int = 8, n_sub=None) -> np.ndarray:
    """``∫_c F(i.h) D(h) G2(i, o, h)/(4 i.n) dω_o`` per cell (zero without an interface)."""
    if not material.has_interface:
        return np.zeros(n * n)
    i = np.asarray(incident, dtype=np.float64)
    if n_sub is None:
        # the lobe in o is ~2x the angular scale of D wide; a cell side spans at most 4/N rad
        # (d theta/d r <= 2): at least 4 nodes per lobe width
        width = 2.0 * mat.angular_scale(material)
        n_sub = int(min(16, max(8, math.ceil(16.0 / (n * n_gauss * width)))))
    o, w, cell = sen.cell_quadrature(n, n_gauss, n_sub)
    h = _unit(o + i)
    ih = h @ i
    val = mat.facet_reflectance(material, ih) * mat.ndf(material, h) * mat.g2_vcavity(i, o, h) / (4.0 * i[2])
    return np.bincount(cell, w * val, minlength=n * n)


def default_n_phi(material: mat.Material, base: int = 48) -> int:
    """Azimuth nodes for normals: ``base`` times half the anisotropy ratio (at least 1)."""
    r = material.roughness
    if "alpha_x" in r:
        ratio = max(r["alpha_x"], r["alpha_y"]) / min(r["alpha_x"], r["alpha_y"])
        return int(base * max(1, math.ceil(ratio / 2.0)))
    return base


def body_cells(material: mat.Material, incident, n: int, n_gauss_o: int = 4, n_sub_o: int = 1,
               n_gauss_m: int = 12, n_phi=None, chunk_elements: int = 4_000_000,
               n_gauss_o_horizon=None) -> np.ndarray:
    """IL body term per cell (zero when ``kd = 0`` or for mirrors); see module docstring.

    ``n_gauss_o`` points per side and piece in each cell, ``n_gauss_o_horizon`` (default
    ``2 n_gauss_o``) in the outer ring of cells that touch the horizon, where the body
    term varies fastest at grazing light.
    """
    if not material.has_body:
        return np.zeros(n * n)
    n_phi = default_n_phi(material) if n_phi is None else n_phi
    i = np.asarray(incident, dtype=np.float64)
    eta = material.eta
    k_body = mat.body_constant(material.kd, eta)
    m, wm, _, _ = mat.normal_quadrature(material, n_gauss_m, n_phi)
    keep = wm > 0.0
    m, wm = m[keep], wm[keep]
    im = m @ i
    lit = im > 0.0
    m, wm, im = m[lit], wm[lit], im[lit]
    g1i = mat.g1_vcavity(i, m)
    # D(m) dω_m = w_m / m_z
    a_m = wm / m[:, 2] * im * mat.fresnel_transmittance(im, eta) * k_body / i[2]
    all_cells = np.arange(n * n)
    ring = (all_cells % n == 0) | (all_cells % n == n - 1) | (all_cells // n == 0) | (all_cells // n == n - 1)
    horizon = 2 * n_gauss_o if n_gauss_o_horizon is None else n_gauss_o_horizon
    parts = [sen.cell_quadrature(n, n_gauss_o, n_sub_o, cells=all_cells[~ring]),
             sen.cell_quadrature(n, horizon, n_sub_o, cells=all_cells[ring])]
    o = np.concatenate([q[0] for q in parts])
    wo = np.concatenate([q[1] for q in parts])
    cell = np.concatenate([q[2] for q in parts])
    out = np.zeros(n * n)
    step = max(1, chunk_elements // o.shape[0])
    for s in range(0, m.shape[0], step):
        mm = m[s:s + step]
        om = o @ mm.T  # (P, M)
        pos = om > 0.0
        omc = np.where(pos, om, 1.0)
        g1o = np.where(pos, np.minimum(1.0, 2.0 * o[:, 2:3] * mm[:, 2][None, :] / omc), 0.0)
        g1o = np.maximum(g1o, 0.0)
        g2 = np.minimum(g1i[s:s + step][None, :], g1o)
        t_o = mat.fresnel_transmittance(np.where(pos, om, 0.0), eta)
        integrand = np.where(pos, om, 0.0) * t_o * g2  # (P, M)
        per_node = integrand @ a_m[s:s + step]  # (P,)
        out += np.bincount(cell, wo * per_node, minlength=n * n)
    return out


def f1_cells(material: mat.Material, incident, n: int, **kw) -> np.ndarray:
    """``P_c`` (specular + body) per cell; its sum is the f1 albedo."""
    spec_kw = {k[5:]: v for k, v in kw.items() if k.startswith("spec_")}
    body_kw = {k[5:]: v for k, v in kw.items() if k.startswith("body_")}
    return specular_cells(material, incident, n, **spec_kw) + body_cells(material, incident, n, **body_kw)


def specular_albedo_half_vector(material: mat.Material, incident, n_gauss: int = 24, n_phi: int = 256) -> float:
    """Specular f1 albedo over the half vector: ``∫ F D(h) G2 (i.h)/(i.n) dω_h`` (W eq. 14).

    Independent of the sensor: a check of :func:`specular_cells` summed over cells.
    """
    if not material.has_interface:
        return 0.0
    i = np.asarray(incident, dtype=np.float64)
    h, wh, _, _ = mat.normal_quadrature(material, n_gauss, n_phi)
    ih = h @ i
    o = 2.0 * ih[:, None] * h - i
    val = np.where(ih > 0.0, mat.facet_reflectance(material, ih) * mat.g2_vcavity(i, o, h) * ih / i[2], 0.0)
    return float(np.sum(wh / h[:, 2] * val))


def body_albedo_direct(material: mat.Material, incident, n_gauss_m: int = 16, n_phi: int = 128,
                       n_mu: int = 48, n_az: int = 96) -> float:
    """Body f1 albedo by a hemispherical rule in ``o`` (no sensor): a check of :func:`body_cells`.

    ``∫ f_b cos θ_o dω_o`` with ``o`` on a Gauss-Legendre grid in ``cos θ_o`` (graded
    toward the horizon as ``mu = 1 - (1 - t)²``) times midpoints in ``φ_o``.
    """
    if not material.has_body:
        return 0.0
    i = np.asarray(incident, dtype=np.float64)
    x, wx = np.polynomial.legendre.leggauss(n_mu)
    t = 0.5 * (x + 1.0)
    mu = 1.0 - (1.0 - t) ** 2
    wmu = 0.5 * wx * 2.0 * (1.0 - t)
    phi = (np.arange(n_az) + 0.5) * 2.0 * math.pi / n_az
    mm, pp = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - mm ** 2)
    o = np.stack([s * np.cos(pp), s * np.sin(pp), mm], -1).reshape(-1, 3)
    wo = (wmu[:, None] * np.full(n_az, 2.0 * math.pi / n_az)[None, :]).ravel()
    # reuse body_cells' integrand with a single "cell"
    eta = material.eta
    k_body = mat.body_constant(material.kd, eta)
    m, wm, _, _ = mat.normal_quadrature(material, n_gauss_m, n_phi)
    im = m @ i
    keep = (im > 0.0) & (wm > 0.0)
    m, wm, im = m[keep], wm[keep], im[keep]
    a_m = wm / m[:, 2] * im * mat.fresnel_transmittance(im, eta) * k_body / i[2]
    g1i = mat.g1_vcavity(i, m)
    total = 0.0
    step = max(1, 4_000_000 // o.shape[0])
    for s0 in range(0, m.shape[0], step):
        mm_ = m[s0:s0 + step]
        om = o @ mm_.T
        pos = om > 0.0
        omc = np.where(pos, om, 1.0)
        g1o = np.where(pos, np.maximum(np.minimum(1.0, 2.0 * o[:, 2:3] * mm_[:, 2][None, :] / omc), 0.0), 0.0)
        g2 = np.minimum(g1i[s0:s0 + step][None, :], g1o)
        integrand = np.where(pos, om, 0.0) * mat.fresnel_transmittance(np.where(pos, om, 0.0), eta) * g2
        total += float(wo @ (integrand @ a_m[s0:s0 + step]))
    return total
