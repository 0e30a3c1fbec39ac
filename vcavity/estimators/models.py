"""An estimator's analytic models: one per incident direction, computed before any path is traced.

The exact-f1 estimator's cell integrals of the first order and the exact estimator's
every-order model are the same kind of object: per direction of a run, a model computed
once before tracing (:meth:`DirectionModels.prepare`, which may refuse a material in one
line), perhaps refined once the counts are known (:meth:`DirectionModels.refine`), whose
time the table reports. An estimator's module subclasses :class:`DirectionModels` and says
how one direction's model is computed (:meth:`~DirectionModels.compute`).
"""

from __future__ import annotations

import time


class DirectionModels:
    """Per incident direction of ``config``, a model (see module doc).

    Parameters
    ----------
    config : vcavity.config.RunConfig
    sensor : vcavity.sensor.grid.EqualAreaSensor

    Attributes
    ----------
    models : list or None
        Per direction, None before :meth:`prepare`.
    time_s : float
        Seconds spent computing and refining them.
    """

    def __init__(self, config, sensor):
        self.config, self.sensor = config, sensor
        self.models: list | None = None
        self.time_s = 0.0

    def compute(self, direction):
        """The model of one incident direction (a :class:`vcavity.config.Incidence`).

        Raises
        ------
        vcavity.analytic.single_bounce.ModelNotApplicable
            The model cannot reach the accuracy the run needs (one line).
        """
        raise NotImplementedError

    def prepare(self, on_direction=None) -> float:
        """Compute every direction's model; ``on_direction(j)`` after each. Returns the seconds
        it took (0 when already prepared)."""
        if self.models is not None:
            return 0.0
        t0 = time.perf_counter()
        models = []
        for j, d in enumerate(self.config.incidence):
            models.append(self.compute(d))
            if on_direction is not None:
                on_direction(j)
        self.models = models
        self.time_s = time.perf_counter() - t0
        return self.time_s

    def ready_line(self, seconds: float) -> str:
        """What ``vcavity run`` says once the models are prepared."""
        return f"{type(self).__name__} ready in {seconds:.2f} s"

    def refine(self, tallies, paths) -> None:
        """Refine the models to the run's counts (``tallies[j]``: direction ``j``'s tally
        planes, ``paths[j]`` its paths); nothing by default."""

    def error_ratio(self, tallies, paths) -> float:
        """Largest ratio of a cell's model error to its statistical error (0 by default)."""
        return 0.0


__all__ = ["DirectionModels"]
