"""The ``paper`` estimator: the IL paper's eq. 23, paths that start on a facet, weighted by its lit area.

Its walk (:mod:`vcavity.kernels.paper`) starts each path at a uniform point of one of the
groove's facets with weight ``w = (i.m_f) V(x) / ((i.n) (m.n))`` (``E[w] = 1``), and sums
the weights of the paths leaving through each cell as integers ``q = floor(w Q + u)``
(stochastic rounding, :data:`WEIGHT_SCALE` ``= Q``), with ``Σ q^2`` for the variance.
``brdf[c] = Σ q / (Q N Ω⊥_c)`` with the standard error of a mean of ``N`` per-path
contributions, ``sqrt(Σ q^2 - (Σ q)^2 / N) / (Q N Ω⊥_c)``; the absorbed, truncated and
degenerate shares are of weight, not of paths. V-cavities only.
"""

from __future__ import annotations

import numpy as np

from vcavity.estimators.counts import SIMULATED, DirectionEstimate, mirror_of, table_counts
from vcavity.parameters import fail

NAME = "paper"
DESCRIPTION = ("the IL paper's eq. 23: paths start on a facet, weighted by its lit projected area "
               "(V-cavities)")
FIRST_BINNED_ORDER = 1
TALLIES = ("counts", "weights", "squares")
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned", "absorbed_weight",
         "truncated_weight", "degenerate_weight")
COUNTS_UNTESTABLE = "its f1 is a weighted estimate, not path counts"
STDERR_RULE = ("not available: the sweep stores no albedo error for estimator 'paper' (weighted paths: the "
               "error needs the per-path weights summed over all cells)")
#: ``Q``, the fixed-point scale of the integer weights: a path of weight ``w`` adds
#: ``q ≈ w Q``; one cell's ``Σ q^2`` stays below 2^63 up to ~10^12 paths of weight 1.
WEIGHT_SCALE = 65536.0


def walk(material) -> str:
    """The walk that starts on a facet (:mod:`vcavity.kernels.paper`)."""
    return "paper"


def check(config, name: str = NAME) -> None:
    """V-cavities only: the estimate is the V-groove walk's (``name``: the estimator refused,
    this one's or another's that shares the rule)."""
    if config.material.microsurface != "v-cavity":
        fail("simulation.estimator", name, "is for the v-cavity microsurface (its estimates are V-groove "
             f"models); with material.microsurface = {config.material.microsurface!r} use 'analog' or 'exact-f1'")


def models(config, sensor) -> None:
    """No analytic model."""
    return None


def weighted(weights, squares, paths: int, scale: float, projected_solid_angle, mirror=None) -> DirectionEstimate:
    """BRDF, standard error and albedo of one direction of a weighted run (module doc).

    Parameters
    ----------
    weights, squares : array_like of int (n_orders, n_cells)
        Per order and cell, ``Σ q`` and ``Σ q^2`` of the integer path weights ``q``.
    paths : int
        Paths started (> 0), zero-weight ones included.
    scale : float
        ``Q``: a path of weight ``w`` has ``q ≈ w Q``.
    projected_solid_angle : array_like (n_cells,)
    mirror : array_like of int (n_cells,), optional
        :func:`vcavity.sensor.mirror.mirror_cells` to fold, or None.

    Returns
    -------
    DirectionEstimate
    """
    n = float(paths)
    area = np.asarray(projected_solid_angle, dtype=np.float64)
    first = np.asarray(weights, dtype=np.float64) / scale
    second = np.asarray(squares, dtype=np.float64) / (scale * scale)
    albedo = first.sum(axis=1) / n
    if mirror is not None:
        mirror = np.asarray(mirror, dtype=np.int64)
        pair = mirror != np.arange(mirror.size)
        first = first + np.where(pair, first[:, mirror], 0.0)
        second = second + np.where(pair, second[:, mirror], 0.0)
        area = np.where(pair, 2.0 * area, area)
    spread = np.sqrt(np.maximum(second - first * first / n, 0.0))
    return DirectionEstimate(brdf=first / (n * area), brdf_stderr=spread / (n * area), albedo=albedo,
                             folded=mirror is not None)


def estimate(j: int, tally, paths: int, config, sensor, models=None) -> DirectionEstimate:
    """Direction ``j`` from its weight sums (``tally[1]``, ``tally[2]``): :func:`weighted`."""
    track = config.track_all_orders
    return weighted(table_counts(tally[1], track), table_counts(tally[2], track), paths, WEIGHT_SCALE,
                    sensor.cell_projected_solid_angle, mirror=mirror_of(config, sensor, j))


def lost_fractions(j: int, stats, paths: int, models=None) -> np.ndarray:
    """Absorbed, truncated and degenerate weight as fractions of the weight started (``Q N``)."""
    columns = [STATS.index(name) for name in ("absorbed_weight", "truncated_weight", "degenerate_weight")]
    return np.asarray(stats, dtype=np.int64)[columns] / (WEIGHT_SCALE * np.int64(paths))


def landed(tally, stats) -> int:
    """Paths binned (every order)."""
    return int(tally[0].sum())


def order_source(orders) -> np.ndarray:
    """Every order simulated."""
    return np.full(len(orders), SIMULATED, dtype=np.int8)


def albedo_stderr(order: int, value, value_f1, paths):
    """None: the error needs the per-path weights summed over all cells, which a sweep does not keep."""
    return None


__all__ = ["NAME", "WEIGHT_SCALE", "estimate", "weighted"]
