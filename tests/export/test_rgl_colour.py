"""The colour values of an RGL export (vcavity/export/rgl.py), read back without Mitsuba.

A reader of the file evaluates (docs/exports.md, "RGL"; Dupuy & Jakob 2018)::

    f(wi, wo) cos(theta_o) = R(s) ndf(u_m) / (4 sigma(u_wi)),   s = vndf^-1(u_m)

with ``m`` the half vector, ``u`` a direction's unit-square coordinates
``(sqrt(2 theta / pi), (phi + pi) / (2 pi))`` (the azimuth of ``m`` relative to ``phi_i``
in an isotropic file), ``ndf``, ``sigma`` and the colour grid ``R`` interpolated
bilinearly on their nodes, and ``vndf^-1`` the inverse of the continuous
marginal-conditional warp of the bilinear ``vndf`` grid: the marginal CDF along ``y``
(the azimuth axis, rows) then the conditional one along ``x`` (``theta``, columns).

Everything here is written from that description in plain NumPy (the file through
tests/reference/tensor_file_reader.py, the warp and the interpolation below), nothing of
vcavity's exporter. The table is a synthetic closed-form one (tests/export/synthetic_table.py,
nothing compiled); ``f`` is its ``Table.eval``. Deterministic: no false-positive rate.

- At every node of the colour grid (the warp run forward by bisection of the CDFs, then
  ``wo`` the mirror of ``wi`` about ``m``) the relation holds to float32 rounding.
- At random pairs (as a renderer asks) it holds within the documented interpolation error
  of the colour grid (median below 0.5 %, 90 % of pairs below 2 %).
"""

import numpy as np
import pytest

from tests.export.synthetic_table import direction, synthetic
from tests.reference.tensor_file_reader import read_tensor_file
from vcavity.cli import main

#: incident polar angles checked (deg): tabulated ones, and 5 deg (a file node the exporter
#: adds between the table's 0 and 10 deg, where Table.eval interpolates two rows)
THETA_DEG = (0.0, 5.0, 30.0, 60.0, 80.0)
EPSILON = float(np.finfo(np.float32).eps) / 2  # readers clip warp samples to [eps, 1 - eps]


def _bilinear(grid, x, y):
    """Bilinear interpolation of ``grid`` (rows ``y``, columns ``x``, nodes at k/(n-1))."""
    grid = np.asarray(grid, dtype=np.float64)
    h, w = grid.shape
    px, py = np.clip(x, 0, 1) * (w - 1), np.clip(y, 0, 1) * (h - 1)
    i, j = np.minimum(np.floor(px).astype(int), w - 2), np.minimum(np.floor(py).astype(int), h - 2)
    a, b = px - i, py - j
    return ((1 - a) * (1 - b) * grid[j, i] + a * (1 - b) * grid[j, i + 1] + (1 - a) * b * grid[j + 1, i]
            + a * b * grid[j + 1, i + 1])


class Warp:
    """The continuous marginal-conditional warp of the bilinear density on ``data`` (H, W)."""

    def __init__(self, data):
        self.v = np.asarray(data, dtype=np.float64)
        h, w = self.v.shape
        self.hx, self.hy = 1.0 / (w - 1), 1.0 / (h - 1)
        # integral along x from 0 to node i of every row (exact for the linear pieces)
        self.row_cum = np.concatenate([np.zeros((h, 1)),
                                       np.cumsum(0.5 * self.hx * (self.v[:, 1:] + self.v[:, :-1]), axis=1)], axis=1)
        self.row_total = self.row_cum[:, -1]
        self.marginal_cum = np.concatenate([[0.0], np.cumsum(0.5 * self.hy * (self.row_total[1:]
                                                                               + self.row_total[:-1]))])

    @staticmethod
    def _cell(t, n):
        position = np.clip(t, 0.0, 1.0) * (n - 1)
        index = np.minimum(np.floor(position).astype(int), n - 2)
        return index, position - index

    def cdf_y(self, y):
        j, b = self._cell(y, self.v.shape[0])
        r0, r1 = self.row_total[j], self.row_total[j + 1]
        return (self.marginal_cum[j] + self.hy * (b * r0 + 0.5 * b * b * (r1 - r0))) / self.marginal_cum[-1]

    def cdf_x(self, x, y):
        j, b = self._cell(y, self.v.shape[0])
        i, a = self._cell(x, self.v.shape[1])
        v0 = (1 - b) * self.v[j, i] + b * self.v[j + 1, i]
        v1 = (1 - b) * self.v[j, i + 1] + b * self.v[j + 1, i + 1]
        below = (1 - b) * self.row_cum[j, i] + b * self.row_cum[j + 1, i]
        total = (1 - b) * self.row_total[j] + b * self.row_total[j + 1]
        return (below + self.hx * (a * v0 + 0.5 * a * a * (v1 - v0))) / total

    def invert(self, x, y):
        """``s`` of the point ``(x, y)``."""
        return self.cdf_x(x, y), self.cdf_y(y)

    def sample(self, sx, sy, steps=64):
        """The point of ``s`` (bisection of the monotone CDFs: y first, then x)."""
        lo, hi = np.zeros_like(sy), np.ones_like(sy)
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            below = self.cdf_y(mid) < sy
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        y = 0.5 * (lo + hi)
        lo, hi = np.zeros_like(sx), np.ones_like(sx)
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            below = self.cdf_x(mid, y) < sx
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return 0.5 * (lo + hi), y


def _u(w):
    """Unit-square coordinates ``(u_theta, u_phi)`` of unit vectors (..., 3)."""
    theta = np.arccos(np.clip(w[..., 2], -1.0, 1.0))
    phi = np.arctan2(w[..., 1], w[..., 0])
    return np.sqrt(theta * 2 / np.pi), (phi + np.pi) / (2 * np.pi)


@pytest.fixture(scope="module", params=["rgl", "rgl-spectral"])
def exported(tmp_path_factory, request):
    folder = tmp_path_factory.mktemp("rgl_colour")
    table = synthetic(folder / "t.h5")
    out = folder / f"t_{request.param}.bsdf"
    assert main(["export", str(table.path), str(out), "--format", request.param]) == 0
    fields = read_tensor_file(out)
    colour = fields["rgb" if request.param == "rgl" else "spectra"]
    return table, fields, colour


def _slice(fields, theta_deg):
    """Index of the file's theta_i node at ``theta_deg`` (isotropic file: phi_i = [0])."""
    assert fields["phi_i"].tolist() == [0.0]
    j = int(np.argmin(np.abs(fields["theta_i"] - np.radians(theta_deg))))
    assert abs(fields["theta_i"][j] - np.radians(theta_deg)) < 1e-6, fields["theta_i"]
    return j


def _reader_factor(fields, wi, u_m):
    """``ndf(u_m) / (4 sigma(u_wi))``, as the reader interpolates both."""
    ux_i, uy_i = _u(wi)
    return _bilinear(fields["ndf"], *u_m) / (4 * _bilinear(fields["sigma"], ux_i, uy_i))


@pytest.mark.parametrize("theta_deg", THETA_DEG)
def test_colour_nodes_hold_f_cos_theta_o_times_4_sigma_over_ndf(exported, theta_deg):
    """At every colour node whose direction is above the horizon (theta_o < 89 deg):
    ``R ndf / (4 sigma) = f cos theta_o`` to 1e-4 relative (float32 storage), every channel."""
    table, fields, colour = exported
    j = _slice(fields, theta_deg)
    wi = direction(np.radians(theta_deg), 0.0)
    n = colour.shape[-1]
    s_y, s_x = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    u_x, u_y = Warp(fields["vndf"][0, j]).sample(np.clip(s_x, EPSILON, 1 - EPSILON),
                                                 np.clip(s_y, EPSILON, 1 - EPSILON))
    m = direction(u_x ** 2 * np.pi / 2, (2 * u_y - 1) * np.pi)
    wo = 2 * (m @ wi)[..., None] * m - wi
    up = wo[..., 2] > np.cos(np.radians(89.0))
    expected = table.eval(np.broadcast_to(wi, wo[up].shape), wo[up]) * wo[up][:, 2]
    assert up.sum() > 0.5 * n * n and np.all(expected > 0)
    factor = _reader_factor(fields, wi, (u_x[up], u_y[up]))
    for channel in range(colour.shape[2]):
        got = colour[0, j, channel].astype(np.float64)[up] * factor
        worst = np.max(np.abs(got - expected) / expected)
        assert worst < 1e-4, (theta_deg, channel, worst)


@pytest.mark.parametrize("theta_deg", THETA_DEG)
def test_a_reader_evaluates_f_cos_theta_o_at_random_pairs(exported, theta_deg):
    """What a renderer gets at 400 random ``wo`` (theta_o < 80 deg) for ``wi`` on a file
    node: median error below 0.5 %, 90 % of pairs below 2 % (docs/exports.md), every channel."""
    table, fields, colour = exported
    j = _slice(fields, theta_deg)
    rng = np.random.default_rng(11)
    wi = direction(np.radians(theta_deg), 0.0)
    wo = direction(np.arccos(rng.uniform(np.cos(np.radians(80.0)), 1.0, 400)), rng.uniform(-np.pi, np.pi, 400))
    m = wi + wo
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    u_m = _u(m)
    s_x, s_y = Warp(fields["vndf"][0, j]).invert(*u_m)
    expected = table.eval(np.broadcast_to(wi, wo.shape), wo) * wo[:, 2]
    factor = _reader_factor(fields, wi, u_m)
    for channel in range(colour.shape[2]):
        got = _bilinear(colour[0, j, channel], s_x, s_y) * factor
        errors = np.abs(got - expected) / expected
        assert np.median(errors) < 0.005 and np.quantile(errors, 0.9) < 0.02, (theta_deg, channel, errors.max())
