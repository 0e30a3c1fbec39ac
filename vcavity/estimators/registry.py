"""The registry of estimators: one module each, the same interface in each, one line to add one.

An estimator decides what a run traces and what its table holds. Each module of
:data:`ESTIMATOR_MODULES` declares, in one place:

==============================  ================================================================
``NAME``, ``DESCRIPTION``       the ``simulation.estimator`` value; one line for ``--help``
``walk(material)``              the walk it needs (a name of :mod:`vcavity.kernels.walks`:
                                ``"v-cavity"``, ``"smith"``, ``"paper"``) or None: traces nothing
``FIRST_BINNED_ORDER``          exits of lower orders are counted, not binned (exact-f1: 2)
``TALLIES``, ``STATS``          the walk's tally planes and statistics columns it keeps, by name
                                (a run's state holds these, in this order)
``check(config)``               its own config checks: one-line ``ConfigError`` naming the field
``models(config, sensor)``      its analytic models (``prepare``, ``refine``, ``error_ratio``,
                                ``ready_line``, ``time_s``), or None
``estimate(j, tally, paths,     direction ``j``'s ``brdf``, ``brdf_stderr``, ``albedo`` and
config, sensor, models)``       fold (:class:`vcavity.estimators.counts.DirectionEstimate`)
``lost_fractions(j, stats,      absorbed, truncated and degenerate shares of direction ``j``
paths, models)``
``landed(tally, stats)``        paths that left the surface (the stop rule's minimum count)
``order_source(orders)``        per order: simulated, analytic or both (int8 flags of
                                :mod:`vcavity.estimators.counts`)
``COUNTS_UNTESTABLE``           None where the counts are path counts a multinomial test
                                reads (compare), else why not (one phrase)
``STDERR_RULE``,                how a sweep's albedo gets a standard error (one line: "not
``albedo_stderr(order, value,   available: ..." where it has none), and the rule on arrays
value_f1, paths)``              (None where there is none)
``WEIGHT_SCALE`` (optional)     a weighted walk's fixed-point scale of the integer weights
==============================  ================================================================

Nothing else in the package compares an estimator's name: the run, the config, the sweep,
the writer, ``compare`` and the exports ask the module. Adding an estimator is a module
with this interface plus one line in :data:`ESTIMATOR_MODULES`.

Importing the registry imports no analytic model and no walk: the models load theirs when
built (:func:`models`), and the walks are the run's (:mod:`vcavity.simulate.pipeline`), so
the consumers of tables (``compare``, the exports, the plots) may ask an estimator.
"""

from __future__ import annotations

import importlib
from types import ModuleType

#: The modules of the room, in the order ``--help`` lists them (the first is the default).
ESTIMATOR_MODULES = ("analog", "exact_f1", "paper", "exact")
#: What every estimator module defines.
INTERFACE = ("NAME", "DESCRIPTION", "walk", "FIRST_BINNED_ORDER", "TALLIES", "STATS", "check", "models",
             "estimate", "lost_fractions", "landed", "order_source", "COUNTS_UNTESTABLE", "STDERR_RULE",
             "albedo_stderr")

def _load(names: tuple[str, ...]) -> tuple[ModuleType, ...]:
    modules = tuple(importlib.import_module(f"vcavity.estimators.{name}") for name in names)
    for module in modules:
        missing = [attr for attr in INTERFACE if not hasattr(module, attr)]
        if missing:
            raise ImportError(f"estimator module {module.__name__} lacks {', '.join(missing)}")
    names_seen = [module.NAME for module in modules]
    if len(set(names_seen)) != len(names_seen):
        raise ImportError(f"estimator names registered twice: {', '.join(names_seen)}")
    return modules


#: The registered modules; lookups read it at call time, so a test may replace it.
MODULES = _load(ESTIMATOR_MODULES)


def names() -> tuple[str, ...]:
    """``NAME`` of every registered estimator, the default first."""
    return tuple(module.NAME for module in MODULES)


def default() -> str:
    """The estimator of a config that names none."""
    return MODULES[0].NAME


def find(name) -> ModuleType | None:
    """The estimator called ``name``, or None when none is registered under it."""
    for module in MODULES:
        if module.NAME == name:
            return module
    return None


def get(name) -> ModuleType:
    """The estimator called ``name``.

    Raises
    ------
    KeyError
        One line naming the value and the registered estimators.
    """
    module = find(name)
    if module is None:
        raise KeyError(f"unknown estimator {name!r}; registered: {', '.join(names())}")
    return module


__all__ = ["ESTIMATOR_MODULES", "INTERFACE", "MODULES", "default", "find", "get", "names"]
