"""An estimator's analytic models: one per incident direction, computed before any path is traced.

The exact-f1 estimator's cell integrals of the first order and the exact estimator's
every-order model are the same kind of object: per direction of a run, a model computed
once before tracing (:meth:`DirectionModels.prepare`, which may refuse a material in one
line), perhaps refined once the counts are known (:meth:`DirectionModels.refine`), whose
time the table reports. An estimator's module subclasses :class:`DirectionModels` and says
how one direction's model is computed (:meth:`~DirectionModels.compute`) and how its
compiled code is compiled on a tiny input (:meth:`~DirectionModels.compile_code`).

The compile comes first (:meth:`DirectionModels.compile`, a run's "compiling the models"
notice and its own time, ``model_compile_time_s``), so that the model time is the
models' own. Computing and refining poll the caller's stop request (``should_stop``)
between short compiled calls (:mod:`vcavity.analytic.batches`) and raise
:class:`~vcavity.analytic.batches.ModelInterrupted` on it; nothing is kept of a model
interrupted half-way.
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
        Seconds spent computing and refining them (not compiling).
    compile_time_s : float
        Seconds spent compiling their code, or loading it from the cache (:meth:`compile`).
    """

    #: What the models' compiled code is, for the notice while it compiles (``vcavity:
    #: compiling the <what> for <material>``).
    CODE = "analytic model"

    def __init__(self, config, sensor):
        self.config, self.sensor = config, sensor
        self.models: list | None = None
        self.time_s = 0.0
        self.compile_time_s = 0.0
        self._compiled = False

    def compile_code(self) -> None:
        """Compile (or load from the cache) every compiled function :meth:`compute` and
        :meth:`refine` call for this config, on a tiny input; nothing by default."""

    def compile(self) -> float:
        """:meth:`compile_code` once; returns its seconds (0 when done already), kept in
        :attr:`compile_time_s`."""
        if self._compiled:
            return 0.0
        t0 = time.perf_counter()
        self.compile_code()
        self._compiled = True
        self.compile_time_s = time.perf_counter() - t0
        return self.compile_time_s

    def compute(self, direction, should_stop=None):
        """The model of one incident direction (a :class:`vcavity.config.Incidence`),
        ``should_stop`` polled between its compiled calls.

        Raises
        ------
        vcavity.analytic.single_bounce.ModelNotApplicable
            The model cannot reach the accuracy the run needs (one line).
        vcavity.analytic.batches.ModelInterrupted
            ``should_stop`` returned True.
        """
        raise NotImplementedError

    def prepare(self, on_direction=None, should_stop=None) -> float:
        """Compute every direction's model (compiling first, :meth:`compile`, when not done);
        ``on_direction(j)`` after each. Returns the seconds the models took, not counting the
        compile (0 when already prepared).

        Raises
        ------
        vcavity.analytic.batches.ModelInterrupted
            ``should_stop`` (a callable, polled between short compiled calls) returned True;
            no model is kept.
        """
        from vcavity.analytic.batches import check_stop  # not at import: the registry loads no model

        if self.models is not None:
            return 0.0
        self.compile()
        t0 = time.perf_counter()
        models = []
        for j, d in enumerate(self.config.incidence):
            check_stop(should_stop)
            models.append(self.compute(d, should_stop))
            if on_direction is not None:
                on_direction(j)
        self.models = models
        self.time_s = time.perf_counter() - t0
        return self.time_s

    def ready_line(self, seconds: float) -> str:
        """What ``vcavity run`` says once the models are prepared."""
        return f"{type(self).__name__} ready in {seconds:.2f} s"

    def refine(self, tallies, paths, should_stop=None) -> None:
        """Refine the models to the run's counts (``tallies[j]``: direction ``j``'s tally
        planes, ``paths[j]`` its paths), ``should_stop`` polled as in :meth:`prepare`;
        nothing by default."""

    def error_ratio(self, tallies, paths) -> float:
        """Largest ratio of a cell's model error to its statistical error (0 by default)."""
        return 0.0


__all__ = ["DirectionModels"]
