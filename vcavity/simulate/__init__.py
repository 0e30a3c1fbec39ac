"""Running a simulation: the run service (plan.py: every check before compiling; service.py: compile, model, trace with checkpoints and Ctrl-C, write), the pipeline of work units, the run's state and the Dask executor.

``Simulation``, ``simulate``, ``RunInterrupted`` and ``incident_vector`` are
importable from here (loaded on first use, so importing a submodule such as
:mod:`vcavity.simulate.interrupts` compiles and imports no Numba code).
"""

_PIPELINE_NAMES = ("RunInterrupted", "Simulation", "incident_vector", "simulate")


def __getattr__(name):
    if name in _PIPELINE_NAMES:
        from vcavity.simulate import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module 'vcavity.simulate' has no attribute {name!r}")


__all__ = list(_PIPELINE_NAMES)
