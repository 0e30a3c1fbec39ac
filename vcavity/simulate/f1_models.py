"""The analytic first order of the exact-f1 estimator, per incident direction (physics.md sec. 11).

With ``estimator = "exact-f1"`` a run's f1 is the cell-averaged V-cavity single-bounce
model (:func:`vcavity.analytic.exact_f1.f1_cell_integrals`), whose quadrature error must
stay below a tenth of each cell's statistical error (:data:`MODEL_TOLERANCE_FACTOR`).
:class:`F1Models` computes it before any path is traced, to a first tolerance from the
path budget (a material whose model cannot reach it is refused there, before tracing),
and refines it once the counts are known.
"""

from __future__ import annotations

import math
import time

import numpy as np

#: exact-f1: the model's quadrature error per cell is kept below this fraction of the
#: cell's statistical standard error.
MODEL_TOLERANCE_FACTOR = 0.1


def statistical_error(seen, paths: float) -> np.ndarray:
    """Per-cell statistical error of a count fraction: ``max(sqrt(n (1 - n/N)), 1) / N``
    (``n`` the cell's simulated count of orders >= 2, ``N`` the paths; one path at least)."""
    return np.maximum(np.sqrt(seen * (1.0 - seen / paths)), 1.0) / paths


class F1Models:
    """Per direction of ``config``, the model's cell integrals and their error estimate.

    Parameters
    ----------
    config : vcavity.config.RunConfig
    sensor : vcavity.sensor.grid.EqualAreaSensor
    incident : callable
        ``incident(theta_i, phi_i) -> unit vector`` toward the light.

    Attributes
    ----------
    models : list of vcavity.analytic.exact_f1.CellModel or None
        Per direction (its ``values`` and ``error`` per cell), None before :meth:`prepare`.
    time_s : float
        Seconds spent computing them.
    """

    def __init__(self, config, sensor, incident):
        self.config, self.sensor, self._incident = config, sensor, incident
        self.models: list | None = None
        self.time_s = 0.0

    def prepare(self) -> float:
        """Every direction's model to ``0.1 / sqrt(N n_cells)``: a tenth of the statistical
        error of a cell that receives an average share ``N / n_cells`` of the budget ``N``.

        Returns the seconds it took (0 when already prepared).

        Raises
        ------
        vcavity.analytic.single_bounce.ModelNotApplicable
            The model cannot reach that accuracy for this material (one line).
        """
        if self.models is not None:
            return 0.0
        from vcavity.analytic.exact_f1 import CellModel

        t0 = time.perf_counter()
        models = []
        for d in self.config.incidence:
            tolerance = MODEL_TOLERANCE_FACTOR / math.sqrt(self.config.path_budget(d) * self.sensor.n_cells)
            models.append(CellModel(self.config.material, self._incident(d.theta_i, d.phi_i), self.sensor,
                                    tolerance))
        self.models = models
        self.time_s = time.perf_counter() - t0
        return self.time_s

    def refine(self, seen_per_direction, paths) -> None:
        """Refine each direction's model where its error exceeds a tenth of the cell's
        statistical error (:func:`statistical_error` of ``seen_per_direction[j]``, the cell
        counts of orders >= 2, over ``paths[j]``), the requirement of physics.md sec. 11.

        The refinement continues from the pre-run rules (:meth:`CellModel.refine_to
        <vcavity.analytic.exact_f1.CellModel.refine_to>`): only the cells over tolerance
        are recomputed. A model that cannot be refined further keeps the finest rules it
        reached and their error, which ``brdf_stderr`` includes and :meth:`error_ratio`
        reports: finished paths are never discarded.
        """
        if self.models is None:
            return
        from vcavity.analytic.single_bounce import ModelNotApplicable

        t0 = time.perf_counter()
        for j, model in enumerate(self.models):
            tolerance = MODEL_TOLERANCE_FACTOR * statistical_error(seen_per_direction[j], float(paths[j]))
            if np.all(model.error <= tolerance):
                continue
            try:
                model.refine_to(tolerance)
            except ModelNotApplicable:
                pass
        self.time_s += time.perf_counter() - t0

    def error_ratio(self, seen_per_direction, paths) -> float:
        """Largest ratio of a cell's model error to its statistical error (0 without models)."""
        if self.models is None:
            return 0.0
        worst = 0.0
        for j, model in enumerate(self.models):
            statistical = statistical_error(seen_per_direction[j], float(paths[j]))
            worst = max(worst, float(np.max(model.error / statistical)))
        return worst

    def of(self, j: int):
        """``(integrals, error)`` of direction ``j``, or ``(None, None)`` without models."""
        if self.models is None:
            return None, None
        return self.models[j].values, self.models[j].error
