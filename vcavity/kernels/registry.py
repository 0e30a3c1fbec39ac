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
``prepare_direction(ix,    jitted: what every path of a direction shares (Smith: ``Lambda(i)``)
iy, iz, params,
dist_kind)``
``trace_path(state, ix,    jitted, compiled apart (:func:`vcavity._numba.dispatch.apart`): one
iy, iz, setup, params,     path, ``-> (state, outcome, bounces, wx, wy, wz, q)`` with an outcome
dist_kind, facet_kind,     code of :mod:`vcavity.kernels.scaffold` and the world-frame exit
facet_variant, facet_data, direction; it draws random numbers only from ``state``, writes no
max_bounces,               memory and never raises
weight_scale)``
========================  ========================================================================

:data:`trace_path` and :data:`prepare_direction` dispatch on a walk's position in the
registry (its ``kind``): a compile-time constant in the loop, so each compiled walk holds
its own tracer and no other. Adding a walk is a module plus one line here; the loop, the
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
                                                "weight_scale"))
#: Per walk, what every path of a direction shares.
prepare_direction = REGISTRY.dispatcher("prepare_direction", ("ix", "iy", "iz", "params", "dist_kind"))

__all__ = ["MODULES", "NAMES", "REGISTRY", "WALK_MODULES", "get", "kind_of", "prepare_direction", "trace_path"]
