"""The registry of walks: one module each, the same interface in each, one line to add one.

A walk is what the slot loop (:mod:`vcavity.kernels.loop`) does to one path. Each module
of :data:`WALK_MODULES` defines:

========================  ========================================================================
``NAME``, ``DESCRIPTION``  the name estimators give it (``walk(material)``); one line
``TALLIES``                its tally planes, counts first (``("counts",)``; a weighted walk
                           adds ``"weights"`` and ``"squares"``: ``Σ q`` and ``Σ q^2``)
``STATS``                  its statistics columns: the loop's five (``absorbed``,
                           ``truncated``, ``degenerate``, ``max_bounces``, ``unbinned``), a
                           weighted walk's three more (``absorbed_weight``, ...)
``WEIGHTED``               whether its paths carry integer weights ``q``
``walkable(distribution)`` None where it can walk the distribution, else why not (one line)
``prepare_direction(ix,    what every path of a direction shares (Smith: ``Lambda(i)``), computed
iy, iz, params,            in Python once a call: the loop's ``setup`` (0 where nothing is shared)
dist_kind)``
``trace_path(kind, state,  jitted, ``inline="always"``: one path, ``-> (state, outcome, bounces,
ix, iy, iz, setup,         wx, wy, wz, q)`` with an outcome code of :mod:`vcavity.kernels.scaffold`
params, dist_kind,         and the world-frame exit direction; it draws random numbers only
facet_kind,                from ``state``, writes no memory and never raises
facet_variant, facet_data,
max_bounces,
weight_scale)``
========================  ========================================================================

``kind`` (the walk's own position, unused by it) comes first with exactly these argument
names: the dispatch compiles a constant kind's call as the module's own code, apart from
the loop and inlined by LLVM, with no wrapper between them
(:func:`vcavity._numba.dispatch.dispatcher`, ``direct``).

:data:`trace_path` dispatches on a walk's position in the registry (its ``kind``): a
compile-time constant in the loop, so each compiled walk holds its own tracer and no other. Adding a walk is a module plus one line here; the loop, the
run and ``vcavity warmup`` serve it with no other edit.
"""

from __future__ import annotations

from vcavity._numba.registry import Registry

#: The walk modules under ``vcavity.kernels``, in dispatch order.
WALK_MODULES = ("trace", "smith", "paper")

REGISTRY = Registry("vcavity.kernels", WALK_MODULES, noun="walk", title="walk",
                    interface=("NAME", "DESCRIPTION", "TALLIES", "STATS", "WEIGHTED", "walkable",
                               "prepare_direction", "trace_path"),
                    owner="vcavity.kernels.registry")
MODULES = REGISTRY.modules
NAMES = REGISTRY.names
get = REGISTRY.get
kind_of = REGISTRY.kind_of

#: Per walk, one path (module doc); ``kind`` a compile-time constant in jitted code.
trace_path = REGISTRY.dispatcher("trace_path", ("state", "ix", "iy", "iz", "setup", "params", "dist_kind",
                                                "facet_kind", "facet_variant", "facet_data", "max_bounces",
                                                "weight_scale"), direct=True)

__all__ = ["MODULES", "NAMES", "REGISTRY", "WALK_MODULES", "get", "kind_of", "trace_path"]
