"""The continuous marginal warp of the RGL export (vcavity/export/marginal2d.py).

References are independent of the module: the density is the bilinear interpolant of
the nodes divided by its exact integral (trapezoid sums are exact for bilinear
functions), checked by a chi-square of warped uniform points (fixed seed, 1e-3 false
positive rate), by the Jacobian of the map (finite differences) and by a round trip.
"""

import numpy as np
import pytest
from scipy import stats

from vcavity.export.marginal2d import Marginal2D


def _nodes(seed, shape=(7, 9)):
    rng = np.random.default_rng(seed)
    data = rng.random(shape) ** 3
    data[0] = 0.0          # a zero row (as the vndf has at theta_m = 0)
    data[:, 3] = 0.0       # and a zero column
    return data


def _bilinear_integral_over_bins(data, bins):
    """Exact integrals of the (unnormalised) bilinear interpolant over a bins x bins grid."""
    h, w = data.shape
    fine = 240  # midpoint rule per bin: exact up to 1e-5 relative for these smooth patches
    g = (np.arange(bins * fine) + 0.5) / (bins * fine)
    x, y = np.meshgrid(g, g, indexing="xy")
    fx, fy = x * (w - 1), y * (h - 1)
    ix, iy = np.minimum(fx.astype(int), w - 2), np.minimum(fy.astype(int), h - 2)
    tx, ty = fx - ix, fy - iy
    v = (data[iy, ix] * (1 - tx) * (1 - ty) + data[iy, ix + 1] * tx * (1 - ty)
         + data[iy + 1, ix] * (1 - tx) * ty + data[iy + 1, ix + 1] * tx * ty)
    return v.reshape(bins, fine, bins, fine).sum(axis=(1, 3))  # [y bin, x bin]


@pytest.mark.parametrize("seed", [1, 2])
def test_round_trip(seed):
    warp = Marginal2D(_nodes(seed))
    rng = np.random.default_rng(10 + seed)
    s_x, s_y = rng.random(50_000), rng.random(50_000)
    x, y = warp.sample(s_x, s_y)
    back_x, back_y = warp.invert(x, y)
    assert np.max(np.abs(back_x - s_x)) < 1e-9 and np.max(np.abs(back_y - s_y)) < 1e-9
    assert np.all((x >= 0) & (x <= 1) & (y >= 0) & (y <= 1))


def test_samples_follow_the_bilinear_density():
    data = _nodes(3)
    warp = Marginal2D(data)
    n = 200_000
    rng = np.random.default_rng(5)
    x, y = warp.sample(rng.random(n), rng.random(n))
    bins = 10
    observed, _, _ = np.histogram2d(y, x, bins=bins, range=[[0, 1], [0, 1]])
    expected = _bilinear_integral_over_bins(data, bins)
    expected = expected / expected.sum() * n
    keep = expected > 5
    statistic = np.sum((observed[keep] - expected[keep]) ** 2 / expected[keep])
    p = stats.chi2.sf(statistic, keep.sum() - 1)
    assert p > 1e-3, f"chi2 {statistic:.1f} on {keep.sum() - 1} dof, p = {p:.2e}"
    assert observed[~keep].sum() <= 5 * max(1, (~keep).sum())


def test_pdf_is_the_jacobian_of_the_inverse():
    warp = Marginal2D(_nodes(4))
    rng = np.random.default_rng(6)
    x, y = rng.uniform(0.05, 0.95, 400), rng.uniform(0.05, 0.95, 400)
    h = 1e-6
    sx_px, sy_px = warp.invert(x + h, y)
    sx_mx, sy_mx = warp.invert(x - h, y)
    sx_py, sy_py = warp.invert(x, y + h)
    sx_my, sy_my = warp.invert(x, y - h)
    jacobian = ((sx_px - sx_mx) * (sy_py - sy_my) - (sx_py - sx_my) * (sy_px - sy_mx)) / (4 * h * h)
    pdf = warp.pdf(x, y)
    ok = pdf > 1e-3
    assert np.allclose(jacobian[ok], pdf[ok], rtol=1e-4)


def test_refuses_bad_data():
    with pytest.raises(ValueError):
        Marginal2D(np.zeros((3, 3)))
    with pytest.raises(ValueError):
        Marginal2D(np.ones((1, 4)))
    with pytest.raises(ValueError):
        Marginal2D(-np.ones((3, 3)))
