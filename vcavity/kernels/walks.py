"""The walks by name, and one call of a walk as a named structure.

An estimator names the walk it needs (:mod:`vcavity.estimators.registry`): ``"v-cavity"``
(the V-groove walk, :mod:`vcavity.kernels.trace`), ``"smith"`` (Smith's random walk,
:mod:`vcavity.kernels.smith`) or ``"paper"`` (the V-groove walk started on a facet,
:mod:`vcavity.kernels.paper`), the walks of :mod:`vcavity.kernels.registry`. :func:`get`
builds a scene's :class:`Walk`, the one slot loop (:mod:`vcavity.kernels.loop`) compiled
for that walk and scene, which a run calls with a :class:`WalkCall` and which answers
with its tally planes and statistics columns by name, summed over its thread slots
(``max_bounces``: the maximum).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vcavity.kernels import loop
from vcavity.kernels import registry as walk_registry
from vcavity.microfacet import registry as distributions


@dataclass(frozen=True)
class WalkCall:
    """The blocks of one incident direction that one call traces, and what the walk needs.

    Attributes
    ----------
    incident : ndarray (3,)
        Unit vector toward the light.
    direction_key : numpy.uint64
        Key of the direction's random streams (:func:`vcavity.rng.direction_key`).
    first_block, n_blocks : int
        Blocks ``first_block .. first_block + n_blocks - 1`` of ``BLOCK_SIZE`` paths.
    n_paths : int
        The direction's paths: its last block is short when not a multiple of ``BLOCK_SIZE``.
    params, facet_data : ndarray
        The distribution's parameter array and the facet's prepared data (the registries).
    max_bounces, max_order, resolution : int
        The bounce cap, the orders kept apart (order slot 0: beyond), the sensor's N.
    n_slots : int
        Thread slots: slot ``s`` traces blocks ``s, s + n_slots, ...``; no result depends on it.
    first_binned_order : int
        Exits of lower orders are counted (``unbinned``), not binned.
    weight_scale : float
        Weighted walks: the fixed-point scale ``Q`` of the integer weights (the estimator's).
    setup : float
        What every path of the direction shares: the walk's ``prepare_direction`` (a
        :class:`Walk` fills it in).
    """

    incident: np.ndarray
    direction_key: np.uint64
    first_block: int
    n_blocks: int
    n_paths: int
    params: np.ndarray
    facet_data: np.ndarray
    max_bounces: int
    max_order: int
    resolution: int
    n_slots: int
    first_binned_order: int = 1
    weight_scale: float = 0.0
    setup: float = 0.0


class Walk:
    """One walk compiled for one scene (a distribution, facet model and facet variant).

    Attributes
    ----------
    name : str
    tallies, stats : tuple of str
        The walk's tally planes and statistics columns.
    kernel : vcavity.kernels.loop.SlotKernel
    """

    def __init__(self, module, dist_kind: int, facet_kind: int, facet_variant: int):
        self.name = module.NAME
        self.tallies = module.TALLIES
        self.stats = module.STATS
        self.kernel = loop.build(walk_registry.kind_of(module.NAME), dist_kind, facet_kind, facet_variant)
        self._prepare, self._dist_kind = module.prepare_direction, dist_kind

    @property
    def compiled(self) -> bool:
        """Whether the walk is compiled (or loaded from the cache) in this process."""
        return bool(self.kernel.walk.overloads)

    def __call__(self, call: WalkCall) -> tuple[dict, dict]:
        """Trace ``call``'s blocks; returns ``(tallies, stats)`` by name, summed over the slots.

        ``tallies[name]`` is int64 ``(max_order + 1, resolution**2)`` (order slot 0: beyond
        ``max_order``); ``stats[name]`` an int (``max_bounces``: the maximum over the slots).
        """
        ix, iy, iz = (float(v) for v in call.incident)
        call = dataclasses.replace(call, setup=float(self._prepare(ix, iy, iz, call.params, self._dist_kind)))
        *planes, per_slot = self.kernel(call)
        tallies = {name: plane.sum(axis=0) for name, plane in zip(self.tallies, planes)}
        stats = {name: (per_slot[:, k].max() if name == "max_bounces" else per_slot[:, k].sum())
                 for k, name in enumerate(self.stats)}
        return tallies, stats


def get(name: str, dist_kind: int, facet_kind: int, facet_variant: int) -> Walk:
    """The walk ``name`` for one scene (its kernel built once per process).

    Raises
    ------
    KeyError
        An unknown walk (naming the registered ones).
    ValueError
        The walk cannot walk the distribution (:func:`vcavity.kernels.smith.walkable`).
    """
    module = walk_registry.get(name)
    reason = module.walkable(distributions.MODULES[distributions.REGISTRY.check_kind(dist_kind, "walks.get")].NAME)
    if reason is not None:
        raise ValueError(reason)
    return Walk(module, dist_kind, facet_kind, facet_variant)


__all__ = ["Walk", "WalkCall", "get"]
