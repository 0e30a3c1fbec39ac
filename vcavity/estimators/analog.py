"""The ``analog`` estimator: every order simulated, weight-1 paths counted per cell.

The material's own walk (the V-groove walk, or Smith's for ``microsurface = "smith"``)
bins every exit; ``brdf[c] = n_c / (N Ω⊥_c)`` with the binomial standard error
``sqrt(n_c (1 - n_c/N)) / (N Ω⊥_c)``, folded about the plane of incidence where the
symmetry is exact (:mod:`vcavity.estimators.counts`, physics.md sec. 6). The albedo of an
order is the fraction of paths that left with it, so a sweep's albedo has the binomial
error ``sqrt(a (1 - a) / N)``.
"""

from __future__ import annotations

import numpy as np

from vcavity.estimators.counts import (SIMULATED, binomial, binomial_albedo_stderr, mirror_of, path_fractions,
                                       table_counts)

NAME = "analog"
DESCRIPTION = "every order simulated (the default)"
FIRST_BINNED_ORDER = 1
TALLIES = ("counts",)
STATS = ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned")
COUNTS_UNTESTABLE = None
STDERR_RULE = "binomial sqrt(a (1 - a) / paths): the albedo is a fraction of independent paths"


def walk(material) -> str:
    """The material's own walk: its microsurface (``"v-cavity"`` or ``"smith"``)."""
    return material.microsurface


def check(config) -> None:
    """Nothing beyond the config's own checks: every material and setting is simulated."""


def models(config, sensor) -> None:
    """No analytic model."""
    return None


def estimate(j: int, tally, paths: int, config, sensor, models=None):
    """Direction ``j`` from its counts (``tally[0]``): :func:`vcavity.estimators.counts.binomial`."""
    counts = table_counts(tally[0], config.track_all_orders)
    return binomial(counts, paths, config.orders, sensor.cell_projected_solid_angle,
                    mirror=mirror_of(config, sensor, j))


def lost_fractions(j: int, stats, paths: int, models=None) -> np.ndarray:
    """Absorbed, truncated and degenerate paths as fractions of the paths traced."""
    return path_fractions(stats, STATS, paths)


def landed(tally, stats) -> int:
    """Paths binned (every order)."""
    return int(tally[0].sum())


def order_source(orders) -> np.ndarray:
    """Every order simulated."""
    return np.full(len(orders), SIMULATED, dtype=np.int8)


def albedo_stderr(order: int, value, value_f1, paths):
    """The binomial error of a fraction of paths (module doc)."""
    return binomial_albedo_stderr(value, paths)


__all__ = ["NAME", "estimate", "walk"]
