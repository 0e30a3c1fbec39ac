"""Walter et al.'s rough dielectric BSDF: reflection and transmission (W eq. 20-21).

Conventions (physics.md sec. 1, 7): ``i`` toward the light, ``o`` toward the viewer,
both pointing away from the interface at the macro normal ``n = +z``; the dielectric
(relative index ``eta >= 1``) lies below (``z < 0``). Either direction may be on either
side: ``eta_i``/``eta_o`` are the indices of the media that ``i``/``o`` are in.

- reflection (same side, W eq. 13, 20): ``h_r = sign(i.n) normalize(i + o)``,
  ``f_r = F(i.h_r) D(h_r) G(i, o, h_r) / (4 |i.n| |o.n|)``;
- transmission (opposite sides, W eq. 16, 21): ``h_t = -normalize(eta_i i + eta_o o)``
  (taken on the ``+z`` side),
  ``f_t = |i.h_t| |o.h_t| / (|i.n| |o.n|) eta_o^2 (1 - F(i.h_t)) D(h_t) G(i, o, h_t)
  / (eta_i (i.h_t) + eta_o (o.h_t))^2``, zero unless ``(i.h_t)(o.h_t) < 0``.

``F`` is the exact dielectric Fresnel term (W eq. 22) with relative index
``eta_t/eta_i`` (total internal reflection from inside). ``G`` is Smith's separable
product (W eq. 23, the paper's choice) by default, with the sidedness
``chi+((v.m)/(v.n))`` of W eq. 23-25; ``"smith-hc"`` (H eq. 99) and ``"vcavity"``
(H eq. 49 with ``|v.n|``) are options; ``shadowing=False`` keeps the masking of ``i``
only (for the furnace identity ``∫ (f_r + f_t) |o.n| dω_o = 1``, H eq. 33, 36).
"""

from __future__ import annotations

import numpy as np

from vcavity.analytic.single_bounce import ModelNotApplicable
from vcavity.analytic.terms import smith_lambda_rows
from vcavity.material import Material
from vcavity.facet.fresnel import fresnel_dielectric_array
from vcavity.microfacet import registry as distributions

WALTER_MASKINGS = ("smith", "smith-hc", "vcavity")


class WalterDielectric:
    """Rough dielectric interface BSDF (W eq. 20-21).

    Parameters
    ----------
    material : vcavity.material.Material
        Its distribution and the facet's ``eta`` (1 when the facet has none; ``kd`` is
        ignored: a bare interface).
    masking : {"smith", "smith-hc", "vcavity"}
    shadowing : bool
        False: ``G = G1(i, m)`` only (masking of the incident side).
    lambda_fit : bool
        Beckmann only: Walter's rational Lambda (W eq. 27).

    Raises
    ------
    ModelNotApplicable
        Smith masking with a distribution whose Smith Lambda is infinite (the Gaussian).
    """

    def __init__(self, material: Material, masking: str = "smith", shadowing: bool = True,
                 lambda_fit: bool = False):
        if masking not in WALTER_MASKINGS:
            raise ValueError(f"masking = {masking!r}: accepted {', '.join(WALTER_MASKINGS)}")
        if masking != "vcavity" and distributions.get(material.distribution).SMITH == "infinite":
            raise ModelNotApplicable(f"Smith masking does not apply to the {material.distribution} distribution")
        self.material = material
        self.masking = masking
        self.shadowing = bool(shadowing)
        self.lambda_fit = bool(lambda_fit)
        self.eta = float(material.facet_params.get("eta", 1.0))
        self.kind, self.params = distributions.params_from(material.distribution, material.distribution_params)

    def _g1(self, v, m):
        """Masking of direction(s) ``v`` (N, 3) for normals ``m`` (N, 3) (W eq. 23-25)."""
        vn = v[:, 2]
        vm = np.sum(v * m, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            side = np.where(vn != 0.0, vm / vn, 0.0) > 0.0
        if self.masking == "vcavity":
            with np.errstate(divide="ignore", invalid="ignore"):
                g = np.minimum(1.0, np.abs(2.0 * m[:, 2] * vn / vm))
            return np.where(side, g, 0.0), None
        mirrored = np.column_stack([v[:, 0], v[:, 1], np.abs(vn)])
        lam = smith_lambda_rows(self.kind, np.ascontiguousarray(mirrored), self.params, self.lambda_fit)
        return np.where(side, 1.0 / (1.0 + lam), 0.0), np.where(side, lam, np.inf)

    def _g(self, i, o, m):
        g_i, lam_i = self._g1(i, m)
        if not self.shadowing:
            return g_i
        g_o, lam_o = self._g1(o, m)
        if self.masking == "smith-hc":
            with np.errstate(invalid="ignore"):
                return np.where((g_i > 0) & (g_o > 0), 1.0 / (1.0 + lam_i + lam_o), 0.0)
        if self.masking == "vcavity":
            return np.minimum(g_i, g_o)
        return g_i * g_o

    def bsdf(self, incident, outgoing) -> np.ndarray:
        """``f_r`` where ``o`` is on the side of ``i``, ``f_t`` across (1/sr), shape (M,)."""
        o = np.ascontiguousarray(np.asarray(outgoing, dtype=np.float64).reshape(-1, 3))
        i = np.broadcast_to(np.asarray(incident, dtype=np.float64).reshape(1, 3), o.shape).copy()
        eta_i = np.where(i[:, 2] > 0.0, 1.0, self.eta)
        eta_o = np.where(o[:, 2] > 0.0, 1.0, self.eta)
        reflect = (i[:, 2] > 0.0) == (o[:, 2] > 0.0)
        # half vectors (W eq. 13, 16), both turned to the +z side where D lives
        h = np.where(reflect[:, None], i + o, -(eta_i[:, None] * i + eta_o[:, None] * o))
        h = h * np.where(h[:, 2] < 0.0, -1.0, 1.0)[:, None]
        norm = np.linalg.norm(h, axis=1)
        valid = (norm > 0.0) & (i[:, 2] != 0.0) & (o[:, 2] != 0.0)
        h = np.where(valid[:, None], h / np.where(norm > 0.0, norm, 1.0)[:, None], [0.0, 0.0, 1.0])
        ih = np.sum(i * h, axis=1)
        oh = np.sum(o * h, axis=1)
        d = distributions.evaluate("D", self.kind, h, self.params)
        fresnel = np.empty(ih.shape[0])
        for outside in (True, False):  # relative index eta_t/eta_i per side of i
            rows = (i[:, 2] > 0.0) == outside
            if np.any(rows):
                fresnel[rows] = fresnel_dielectric_array(np.abs(ih[rows]), self.eta if outside else 1.0 / self.eta)
        g = self._g(i, o, h)
        cos_io = np.abs(i[:, 2] * o[:, 2])
        with np.errstate(divide="ignore", invalid="ignore"):
            f_r = fresnel * d * g / (4.0 * cos_io)
            denominator = (eta_i * ih + eta_o * oh) ** 2
            f_t = (np.abs(ih * oh) / cos_io * eta_o**2 * (1.0 - fresnel) * d * g / denominator)
        f_t = np.where(ih * oh < 0.0, f_t, 0.0)
        value = np.where(reflect, f_r, f_t)
        return np.where(valid & np.isfinite(value), value, 0.0)

    def brdf(self, incident, outgoing) -> np.ndarray:
        """Reflection part ``f_r`` (W eq. 20); 0 for ``o`` across the interface."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        same = (o[:, 2] > 0.0) == (float(np.asarray(incident).reshape(3)[2]) > 0.0)
        return np.where(same, self.bsdf(incident, o), 0.0)

    def btdf(self, incident, outgoing) -> np.ndarray:
        """Transmission part ``f_t`` (W eq. 21); 0 for ``o`` on the side of ``i``."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        same = (o[:, 2] > 0.0) == (float(np.asarray(incident).reshape(3)[2]) > 0.0)
        return np.where(same, 0.0, self.bsdf(incident, o))

    def projected(self, incident, outgoing) -> np.ndarray:
        """``f |cos θ_o|`` (reflection or transmission by the side of ``o``)."""
        o = np.asarray(outgoing, dtype=np.float64).reshape(-1, 3)
        return self.bsdf(incident, o) * np.abs(o[:, 2])
