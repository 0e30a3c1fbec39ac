"""A table as a continuous BRDF for renderers: eval, pdf, sample, albedo (docs/table-api.md).

A table stores, per incident direction ``j``, order ``k`` and sensor cell ``c``, the
cosine-weighted cell average of the BRDF (physics.md sec. 6)::

    brdf[j, k, c] = (1/Ω⊥_c) ∫_c f_k(i_j, o) cos θ_o dω_o      (1/sr)

This is an average of ``f`` itself (weight ``cos θ_o``), not of ``f cos θ_o``, so
:meth:`TableBRDF.eval` returns an interpolation of these values with no division by a
cosine: it is finite up to the horizon. Interpolation (docs/table-api.md):

- in ``o``: bilinear in the sensor's square coordinates ``(u, v)`` between cell centres,
  constant from the outermost centres to the edge of the square (the horizon), so it is
  exact at cell centres and continuous everywhere;
- in ``i``: linear in ``theta_i`` between tabulated ``theta_i`` (constant beyond the first
  and last); an isotropic table serves any ``phi_i`` by rotating ``o`` by
  ``-(phi(i) - phi_j)`` into row ``j``'s frame; an anisotropic one interpolates linearly in
  ``phi_i`` between tabulated azimuths at most 90 deg apart and refuses other azimuths.

Sampling draws ``(u, v)`` from ``G``, the bilinear interpolant of ``brdf[c] Ω⊥_c/Ω_c``
(about ``f cos θ_o``; its nodes on the square's edge, the horizon, are 0) on the same
patches, mixed over the serving incident rows in proportion to ``w_j ∫∫ G_j du dv``; the map
is equal-area, ``dω = (π/2) du dv``. :meth:`TableBRDF.pdf` is that density exactly,
continuous, and positive wherever :meth:`TableBRDF.eval` is (below the horizon both are 0).
Which rows serve an incident direction is :mod:`vcavity.brdf.incidence`.

Plain NumPy: nothing here imports Numba (reading and evaluating a table compiles nothing).
"""

from __future__ import annotations

import numpy as np

from vcavity.brdf.arguments import _directions, _uniform, _unit
from vcavity.brdf.incidence import MAX_PHI_GAP, DirectionNotTabulated, IncidentRows
from vcavity.sensor.grid import square_to_hemisphere_array

_FOUR_OVER_PI = 4.0 / np.pi


def hemisphere_to_square_array(directions):
    """Inverse concentric map of unit directions to the square ``[-1, 1]^2``, vectorised.

    The NumPy counterpart of :func:`vcavity.sensor.binning.hemisphere_to_square` (same branches:
    ``r^2 = (x^2 + y^2)/(1 + z)``, the larger of ``|x|, |y|`` picks the wedge, the other
    coordinate is ``r (4/π) atan(ratio)``; physics.md sec. 6).

    Parameters
    ----------
    directions : array_like, shape (..., 3)
        Upper-hemisphere unit directions (``z`` is clamped to ``[0, 1]``).

    Returns
    -------
    u, v : numpy.ndarray, shape (...)
    """
    d = np.asarray(directions, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], np.clip(d[..., 2], 0.0, 1.0)
    radius = np.sqrt(np.minimum((x * x + y * y) / (1.0 + z), 1.0))
    y_major = np.abs(y) > np.abs(x)  # ties take the x-branch, as the kernel does
    with np.errstate(divide="ignore", invalid="ignore"):
        major = np.where(y_major, np.copysign(radius, y), np.copysign(radius, x))
        minor = major * (_FOUR_OVER_PI * np.arctan(np.where(y_major, x / y, y / x)))
    minor = np.where(radius > 0.0, minor, 0.0)
    major = np.where(radius > 0.0, major, 0.0)
    return np.where(y_major, minor, major), np.where(y_major, major, minor)


def material_is_isotropic(material: dict) -> bool:
    """Whether a table's ``/material`` is invariant under rotation about the normal.

    Decided from the stored values (the distribution registry imports Numba): the only
    anisotropic parameter of every distribution is the stretched roughness
    (``vcavity.parameters.Roughness``), anisotropic when ``alpha_x != alpha_y``.
    """
    if "alpha_x" in material and "alpha_y" in material:
        return float(material["alpha_x"]) == float(material["alpha_y"])
    return True


def _rotate_z(vectors, cos_a, sin_a):
    """Rotate ``(..., 3)`` vectors by angle ``a`` about ``+z`` (counter-clockwise seen from +z)."""
    x, y = vectors[..., 0], vectors[..., 1]
    return np.stack([cos_a * x - sin_a * y, sin_a * x + cos_a * y, vectors[..., 2]], axis=-1)


def _sample_linear(u, a, b):
    """Inverse CDF on [0, 1] of the density ``∝ (1 - x) a + x b`` (a, b >= 0).

    ``x = u (a + b) / (a + sqrt((1 - u) a^2 + u b^2))``, the cancellation-free form of
    pbrt-v4's ``SampleLinear``; uniform where ``a = b = 0``.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        x = u * (a + b) / (a + np.sqrt((1.0 - u) * a * a + u * b * b))
    return np.clip(np.where(a + b > 0.0, x, u), 0.0, 1.0)


class _Grid:
    """Node coordinates of the bilinear interpolation along one side of the square.

    Nodes: ``-1``, the ``N`` cell centres ``(2i + 1 - N)/N`` (as in
    ``EqualAreaSensor.cell_center``), ``+1``. For ``eval`` the end nodes repeat the
    outermost cells' values (constant between the last centre and the edge); for the
    sampling density ``G`` they are 0 (``f cos θ_o`` vanishes at the horizon).
    Interval ``k`` (0..N) runs from node ``k`` to node ``k + 1``.
    """

    def __init__(self, n):
        self.n = n
        centres = (2.0 * np.arange(n) + 1.0 - n) / n
        self.nodes = np.concatenate([[-1.0], centres, [1.0]])
        self.widths = np.diff(self.nodes)  # h/2, h, ..., h, h/2 with h = 2/N

    def locate(self, s):
        """Interval index in ``0..N`` and fraction in ``[0, 1]`` of square coordinates ``s``."""
        k = np.clip(np.floor((s + 1.0) * (0.5 * self.n) + 0.5), 0, self.n).astype(np.int64)
        return k, np.clip((s - self.nodes[k]) / self.widths[k], 0.0, 1.0)


def _bilinear(nodes, rows, kx, tx, ky, ty):
    """Bilinear value of ``nodes[rows]`` ((n_i, N + 2, N + 2) extended grids) in patch ``(ky, kx)``."""
    return ((1.0 - ty) * ((1.0 - tx) * nodes[rows, ky, kx] + tx * nodes[rows, ky, kx + 1])
            + ty * ((1.0 - tx) * nodes[rows, ky + 1, kx] + tx * nodes[rows, ky + 1, kx + 1]))


class TableBRDF:
    """The renderer view of a :class:`vcavity.io.table.Table` (docs/table-api.md).

    Parameters
    ----------
    table : vcavity.io.table.Table
        Usually reached as ``table.interpolant`` (built once per table).

    Attributes
    ----------
    isotropic : bool
        From the stored material (:func:`material_is_isotropic`); an isotropic table serves
        every incident azimuth by rotation.

    Notes
    -----
    All methods broadcast directions of shape ``(..., 3)`` (world frame: macro normal
    ``+z``, both directions pointing away from the surface; normalised here, without
    under- or overflow; a NaN or infinite component raises ``ValueError``) and take
    ``order`` (0 = all orders, ``f_inf``; ``k`` = exactly ``k`` bounces), which must be in
    the table (``ValueError`` otherwise).
    """

    def __init__(self, table):
        self.table = table
        self.isotropic = material_is_isotropic(table.material)
        self._grid = _Grid(table.sensor.resolution)
        self._per_order = {}
        self._incident = IncidentRows(table.theta_i, table.phi_i, self.isotropic, table.path)

    # ------------------------------------------------------------------ precomputation
    def _order_data(self, order):
        """Extended node grids of ``brdf`` (eval) and ``G`` (pdf), patch CDFs, totals."""
        k = self.table.order_index(order)
        if k not in self._per_order:
            n, n_i = self._grid.n, self.table.theta_i.size
            brdf = np.asarray(self.table.brdf[:, k, :], dtype=np.float64)
            # G: brdf times the mean cos of the cell, Ω⊥_c / Ω_c, i.e. about f cos θ_o
            mean_cos = (np.asarray(self.table.cell_projected_solid_angle)
                        / np.asarray(self.table.cell_solid_angle))
            pad = ((0, 0), (1, 1), (1, 1))
            f_nodes = np.pad(brdf.reshape(n_i, n, n), pad, mode="edge")  # [j, iy, ix]
            # G's end nodes lie on the horizon, where f cos θ_o vanishes: 0, not the edge value
            g_nodes = np.pad((brdf * mean_cos).reshape(n_i, n, n), pad)
            area = np.outer(self._grid.widths, self._grid.widths)  # patch [ky, kx]
            mass = 0.25 * area * (g_nodes[:, :-1, :-1] + g_nodes[:, :-1, 1:]
                                  + g_nodes[:, 1:, :-1] + g_nodes[:, 1:, 1:])
            cdf = np.cumsum(mass.reshape(n_i, -1), axis=1)
            total = cdf[:, -1].copy()  # ∫∫ G du dv, about (2/π) Σ_c brdf Ω⊥_c = (2/π) albedo
            with np.errstate(divide="ignore", invalid="ignore"):
                cdf = np.where(total[:, None] > 0.0, cdf / total[:, None], 0.0)
            albedo = np.asarray(self.table.albedo[:, k], dtype=np.float64)
            self._per_order[k] = (f_nodes, g_nodes, cdf, total, albedo)
        return self._per_order[k]

    # ------------------------------------------------------------------ public API
    def eval(self, wi, wo, order=0):
        """The interpolated BRDF ``f(wi, wo)`` of order ``order``, 1/sr.

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
            Directions toward the light and toward the viewer; broadcast together.
        order : int
            Bounce order (0 = ``f_inf``).

        Returns
        -------
        numpy.ndarray, shape (...)
            ``f`` (not ``f cos θ_o``): the table's cosine-weighted cell averages,
            interpolated (docs/table-api.md); 0 where ``wi_z <= 0`` or ``wo_z <= 0``.

        Raises
        ------
        DirectionNotTabulated
            ``wi`` has an azimuth an anisotropic table does not cover.
        """
        f_nodes = self._order_data(order)[0]
        wi, wo, shape = _directions(wi, wo)
        return self._interpolate(f_nodes, wi, wo).reshape(shape)

    def _interpolate(self, nodes, wi, wo, weights_out=False):
        rows, weights, angle = self._incident.serving(wi)
        value = np.zeros(wi.shape[0])
        up = wo[:, 2] > 0.0
        for q in range(4):
            live = up & (weights[:, q] > 0.0)
            if not np.any(live):
                continue
            local = _rotate_z(wo[live], np.cos(angle[live, q]), -np.sin(angle[live, q]))
            u, v = hemisphere_to_square_array(local)
            kx, tx = self._grid.locate(u)
            ky, ty = self._grid.locate(v)
            value[live] += weights[live, q] * _bilinear(nodes, rows[live, q], kx, tx, ky, ty)
        return (value, rows, weights) if weights_out else value

    def pdf(self, wi, wo, order=0):
        """Density of :meth:`sample` in solid angle, 1/sr.

        ``pdf = (2/π) Σ_j w_j G_j(o_j) / Σ_j w_j T_j`` with ``w_j`` the incident weights,
        ``G_j`` the bilinear interpolant of ``brdf Ω⊥/Ω`` of row ``j``, ``T_j`` its integral
        over the square and ``o_j`` the rotated ``wo`` (docs/table-api.md). 0 below the
        horizon and where the interpolated albedo is 0.

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
        order : int

        Returns
        -------
        numpy.ndarray, shape (...)
        """
        _, g_nodes, _, total, _ = self._order_data(order)
        wi, wo, shape = _directions(wi, wo)
        value, rows, weights = self._interpolate(g_nodes, wi, wo, weights_out=True)
        norm = np.sum(weights * total[rows], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = np.where(norm > 0.0, (2.0 / np.pi) * value / norm, 0.0)
        return pdf.reshape(shape)

    def sample(self, wi, u1, u2, order=0):
        """Draw outgoing directions from the tabulated distribution.

        Parameters
        ----------
        wi : array_like, shape (..., 3)
        u1, u2 : array_like, shape (...)
            Independent uniforms in ``[0, 1)``; broadcast with ``wi[..., 0]``. A value
            outside (or NaN) raises ``ValueError``: it has no direction to map to.
        order : int

        Returns
        -------
        wo : numpy.ndarray, shape (..., 3)
            Unit directions with ``z >= 0``; ``(0, 0, 1)`` where nothing can be sampled
            (``wi_z <= 0`` or interpolated albedo 0), with weight and pdf 0.
        weight : numpy.ndarray, shape (...)
            ``eval(wi, wo) cos θ_o / pdf``, about the albedo of ``wi``.
        pdf : numpy.ndarray, shape (...)
            ``pdf(wi, wo)``, 1/sr.
        """
        _, _, cdf, total, _ = self._order_data(order)
        wi = _unit(wi, "wi")
        u1, u2 = _uniform("u1", u1), _uniform("u2", u2)
        shape = np.broadcast_shapes(wi.shape[:-1], u1.shape, u2.shape)
        wi = np.broadcast_to(wi, shape + (3,)).reshape(-1, 3)
        u1 = np.broadcast_to(u1, shape).ravel()
        u2 = np.broadcast_to(u2, shape).ravel()
        rows, weights, angle = self._incident.serving(wi)
        mix = weights * total[rows]  # choose row j with probability ∝ w_j T_j
        norm = mix.sum(axis=1)
        ok = norm > 0.0
        cumulative = np.cumsum(mix, axis=1) / np.where(ok, norm, 1.0)[:, None]
        q = np.minimum(np.sum(cumulative <= u1[:, None], axis=1), 3)
        q = _last_positive(mix, q)
        index = np.arange(wi.shape[0])
        lower = np.where(q > 0, cumulative[index, np.maximum(q - 1, 0)], 0.0)
        share = np.where(ok, mix[index, q] / np.where(ok, norm, 1.0), 1.0)
        u1 = np.clip((u1 - lower) / np.where(share > 0.0, share, 1.0), 0.0, 1.0)
        local = self._sample_rows(rows[index, q], u1, u2, order)
        chosen = angle[index, q]  # back from the row's frame: rotate by +angle
        wo = _rotate_z(local, np.cos(chosen), np.sin(chosen))
        wo[~ok] = (0.0, 0.0, 1.0)
        pdf = self.pdf(wi, wo, order)
        f = self.eval(wi, wo, order)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = np.where(pdf > 0.0, f * wo[:, 2] / pdf, 0.0)
        pdf = np.where(ok, pdf, 0.0)
        return wo.reshape(shape + (3,)), weight.reshape(shape), pdf.reshape(shape)

    def _sample_rows(self, rows, u1, u2, order):
        """Directions in each row's own frame: a patch by its CDF, then the bilinear in it."""
        _, g_nodes, cdf, _, _ = self._order_data(order)
        n_patch = self._grid.n + 1
        patch = np.empty(rows.size, dtype=np.int64)
        remainder = np.empty(rows.size)
        for j in np.unique(rows):
            pick = rows == j
            p = np.minimum(np.searchsorted(cdf[j], u1[pick], side="right"), cdf.shape[1] - 1)
            below = np.where(p > 0, cdf[j][np.maximum(p - 1, 0)], 0.0)
            width = cdf[j][p] - below
            patch[pick] = p
            remainder[pick] = np.where(width > 0.0, (u1[pick] - below) / np.where(
                width > 0.0, width, 1.0), 0.5)
        ky, kx = patch // n_patch, patch % n_patch
        g00, g10 = g_nodes[rows, ky, kx], g_nodes[rows, ky, kx + 1]
        g01, g11 = g_nodes[rows, ky + 1, kx], g_nodes[rows, ky + 1, kx + 1]
        s = _sample_linear(np.clip(remainder, 0.0, 1.0), g00 + g01, g10 + g11)  # marginal in u
        t = _sample_linear(u2, (1.0 - s) * g00 + s * g10, (1.0 - s) * g01 + s * g11)
        nodes, widths = self._grid.nodes, self._grid.widths
        u = np.clip(nodes[kx] + s * widths[kx], -1.0, 1.0)
        v = np.clip(nodes[ky] + t * widths[ky], -1.0, 1.0)
        return square_to_hemisphere_array(u, v).reshape(-1, 3)

    def albedo(self, wi, order=0):
        """Directional albedo ``Σ_c brdf_c Ω⊥_c`` of order ``order``, interpolated like eval.

        Parameters
        ----------
        wi : array_like, shape (..., 3)
        order : int

        Returns
        -------
        numpy.ndarray, shape (...)
            The stored albedo of the serving rows, weighted as :meth:`eval` weights them
            (linear in ``theta_i``); 0 where ``wi_z <= 0``.
        """
        albedo = self._order_data(order)[4]
        wi = _unit(wi, "wi")
        shape = wi.shape[:-1]
        rows, weights, _ = self._incident.serving(wi.reshape(-1, 3))
        return np.sum(weights * albedo[rows], axis=1).reshape(shape)


def _last_positive(mix, q):
    """Move a choice that rounding put past the last positive-weight candidate back onto it.

    Counting ``cumulative <= u`` skips every zero-weight candidate except trailing ones,
    reached only when rounding leaves the last cumulative value below ``u``.
    """
    positive = mix > 0.0
    last = np.where(positive.any(axis=1), 3 - np.argmax(positive[:, ::-1], axis=1), 0)
    return np.where(positive[np.arange(mix.shape[0]), q], q, last)


__all__ = ["DirectionNotTabulated", "MAX_PHI_GAP", "TableBRDF", "hemisphere_to_square_array",
           "material_is_isotropic"]
