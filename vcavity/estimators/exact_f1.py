"""The ``exact-f1`` estimator: f1 from the microsurface's exact single-bounce model, orders >= 2 simulated.

The first order is the cell-averaged single-bounce model of the microsurface (the
V-cavity model, or the height-correlated Smith model for ``microsurface = "smith"``:
:func:`vcavity.analytic.exact_f1.f1_cell_integrals`, physics.md sec. 11); the walk counts
but does not bin the paths that leave after one bounce (``FIRST_BINNED_ORDER = 2``) and
bins the others. With ``I_c = ∫_c f1 cos θ_o dω_o`` and its quadrature error ``e_c``:
``f1 = I_c / Ω⊥_c``, ``f_inf = I_c / Ω⊥_c + n_inf,c / (N Ω⊥_c)`` and the quadrature error
is added to the statistical one in quadrature, ``stderr = sqrt(n (1 - n/N) / N^2 + e_c^2) / Ω⊥_c``
(:func:`vcavity.estimators.counts.binomial`).

:class:`F1Models` keeps each cell's quadrature error below a tenth of its statistical error
(:data:`MODEL_TOLERANCE_FACTOR`): computed before any path is traced, to a first tolerance
from the path budget (a material whose model cannot reach it is refused there, before
tracing), and refined once the counts are known.
"""

from __future__ import annotations

import math
import time

import numpy as np

from vcavity.estimators import analog
from vcavity.estimators.counts import (ANALYTIC, ANALYTIC_PLUS_SIMULATED, SIMULATED, binomial,
                                       binomial_albedo_stderr, mirror_of, table_counts)
from vcavity.estimators.models import DirectionModels
from vcavity.parameters import fail

NAME = "exact-f1"
DESCRIPTION = ("f1 from the exact single-bounce model of the microsurface (V-cavity; height-correlated "
               "Smith for microsurface = 'smith'), orders >= 2 simulated")
FIRST_BINNED_ORDER = 2
TALLIES = analog.TALLIES
STATS = analog.STATS
COUNTS_UNTESTABLE = None
STDERR_RULE = ("f1 analytic (no statistical error; quadrature error neglected); other orders binomial "
               "sqrt(p (1 - p) / paths) of the simulated fraction p (f_inf: p = E_inf - E_f1)")
#: The model's quadrature error per cell is kept below this fraction of the cell's
#: statistical standard error.
MODEL_TOLERANCE_FACTOR = 0.1

walk = analog.walk
lost_fractions = analog.lost_fractions


def check(config) -> None:
    """Something must be simulated: not ``max_order = 1`` without f_inf."""
    if not config.track_all_orders and config.max_order == 1:
        fail("simulation.estimator", NAME, "with max_order = 1 and track_all_orders = false every order is "
             "analytic and nothing is simulated: use 'analog' or raise max_order")


def models(config, sensor) -> "F1Models":
    """Every direction's f1 cell model (:class:`F1Models`), computed by its ``prepare``."""
    return F1Models(config, sensor)


def estimate(j: int, tally, paths: int, config, sensor, models):
    """Direction ``j``: the model's f1 plus the binned orders >= 2 (module doc)."""
    integrals, error = models.of(j)
    counts = table_counts(tally[0], config.track_all_orders)
    return binomial(counts, paths, config.orders, sensor.cell_projected_solid_angle,
                    mirror=mirror_of(config, sensor, j), f1_integrals=integrals, f1_error=error)


def landed(tally, stats) -> int:
    """Paths binned, and the first-order exits counted but not binned."""
    return int(tally[0].sum()) + int(stats[STATS.index("unbinned")])


def order_source(orders) -> np.ndarray:
    """f1 analytic, f_inf analytic plus simulated, the others simulated."""
    return np.array([ANALYTIC if k == 1 else ANALYTIC_PLUS_SIMULATED if k == 0 else SIMULATED for k in orders],
                    dtype=np.int8).reshape(len(orders))


def albedo_stderr(order: int, value, value_f1, paths):
    """None for f1 (analytic); binomial for orders >= 2 and, of ``E_inf - E_f1``, for f_inf."""
    if int(order) == 1:
        return None
    value = np.asarray(value, dtype=np.float64)
    if int(order) == 0:
        if value_f1 is None:
            return None
        value = value - np.asarray(value_f1, dtype=np.float64)  # the simulated part: exits after >= 2 bounces
    return binomial_albedo_stderr(value, paths)


def statistical_error(seen, paths: float) -> np.ndarray:
    """Per-cell statistical error of a count fraction: ``max(sqrt(n (1 - n/N)), 1) / N``
    (``n`` the cell's simulated count of orders >= 2, ``N`` the paths; one path at least)."""
    return np.maximum(np.sqrt(seen * (1.0 - seen / paths)), 1.0) / paths


def _seen(tallies):
    """Per direction, the simulated cell counts of orders >= 2 (every order slot)."""
    return [np.asarray(tally[0]).sum(axis=0).astype(np.float64) for tally in tallies]


class F1Models(DirectionModels):
    """Per direction of ``config``, the model's cell integrals and their error estimate
    (:class:`vcavity.analytic.exact_f1.CellModel`: its ``values`` and ``error`` per cell).

    :meth:`prepare` computes every direction's model to ``0.1 / sqrt(N n_cells)``: a tenth
    of the statistical error of a cell that receives an average share ``N / n_cells`` of
    the budget ``N`` (a material whose model cannot reach it is refused, one line, before
    any path is traced); :meth:`refine` brings each cell within a tenth of its statistical
    error once the counts are known.
    """

    CODE = "exact f1 model"

    def compile_code(self) -> None:
        """Compile the cell model for the run's material (:func:`compile_model
        <vcavity.analytic.exact_f1.compile_model>`)."""
        from vcavity.analytic.exact_f1 import compile_model

        compile_model(self.config.material)

    def compute(self, direction, should_stop=None):
        """The cell model of one direction (module doc)."""
        from vcavity.analytic.exact_f1 import CellModel
        from vcavity.sensor.directions import incident_vector

        tolerance = MODEL_TOLERANCE_FACTOR / math.sqrt(self.config.path_budget(direction) * self.sensor.n_cells)
        return CellModel(self.config.material, incident_vector(direction.theta_i, direction.phi_i), self.sensor,
                         tolerance, should_stop=should_stop)

    def ready_line(self, seconds: float) -> str:
        """What ``vcavity run`` says once the models are prepared."""
        return f"exact f1 model ready in {seconds:.2f} s"

    def refine(self, tallies, paths, should_stop=None) -> None:
        """Refine each direction's model where its error exceeds a tenth of the cell's
        statistical error (:func:`statistical_error` of the cell counts of orders >= 2,
        ``tallies[j][0]`` summed over order slots, over ``paths[j]``), the requirement of
        physics.md sec. 11.

        The refinement continues from the pre-run rules (:meth:`CellModel.refine_to
        <vcavity.analytic.exact_f1.CellModel.refine_to>`): only the cells over tolerance
        are recomputed. A model that cannot be refined further keeps the finest rules it
        reached and their error, which ``brdf_stderr`` includes and :meth:`error_ratio`
        reports: finished paths are never discarded. ``should_stop`` is polled between the
        model's compiled calls (:class:`~vcavity.analytic.batches.ModelInterrupted`).
        """
        if self.models is None:
            return
        from vcavity.analytic.single_bounce import ModelNotApplicable

        t0 = time.perf_counter()
        for j, (model, seen) in enumerate(zip(self.models, _seen(tallies))):
            tolerance = MODEL_TOLERANCE_FACTOR * statistical_error(seen, float(paths[j]))
            if np.all(model.error <= tolerance):
                continue
            try:
                model.refine_to(tolerance, should_stop=should_stop)
            except ModelNotApplicable:
                pass
        self.time_s += time.perf_counter() - t0

    def error_ratio(self, tallies, paths) -> float:
        """Largest ratio of a cell's model error to its statistical error (0 without models)."""
        if self.models is None:
            return 0.0
        worst = 0.0
        for j, (model, seen) in enumerate(zip(self.models, _seen(tallies))):
            statistical = statistical_error(seen, float(paths[j]))
            worst = max(worst, float(np.max(model.error / statistical)))
        return worst

    def of(self, j: int):
        """``(integrals, error)`` of direction ``j``, or ``(None, None)`` before :meth:`prepare`."""
        if self.models is None:
            return None, None
        return self.models[j].values, self.models[j].error


__all__ = ["MODEL_TOLERANCE_FACTOR", "NAME", "F1Models", "statistical_error"]
