"""The walks by name, and one call of a walk as a named structure.

An estimator names the walk it needs (:mod:`vcavity.estimators.registry`): ``"v-cavity"``
(the V-groove walk, :mod:`vcavity.kernels.trace`), ``"smith"`` (Smith's random walk,
:mod:`vcavity.kernels.smith`) or ``"paper"`` (the V-groove walk started on a facet,
:mod:`vcavity.kernels.paper`), the walks of :mod:`vcavity.kernels.registry`. :func:`get`
builds a scene's :class:`Walk`, the one slot loop (:mod:`vcavity.kernels.loop`) compiled
for that walk and scene, which a run calls with a :class:`WalkCall` and which answers
with its tally planes and statistics columns by name, summed over its thread slots
(``max_bounces``: the maximum). On ``device="cuda"`` the loop is the CUDA kernel
(:mod:`vcavity.kernels.cuda_loop`, numba-cuda imported only then): the same call traces
the call's blocks in one launch and answers the same way.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from vcavity.kernels import loop
from vcavity.kernels import registry as walk_registry
from vcavity.microfacet import registry as distributions

#: Where a walk runs: the CPU's slot loop, or the CUDA kernel (as ``simulation.device``).
DEVICES = ("cpu", "cuda")


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
    device : str
        ``"cpu"`` or ``"cuda"`` (:data:`DEVICES`).
    kernel : vcavity.kernels.loop.SlotKernel or vcavity.kernels.cuda_loop.CudaKernel
        The CPU's slot loop, or on ``"cuda"`` the CUDA kernel: both take a
        :class:`WalkCall` and give per-slot tallies (the kernel one slot row, its
        ``n_slots`` unused). The CUDA kernel is built when first asked for, so that a
        process that only sends the walk's work to GPU workers (``--dask``) needs no
        numba-cuda.
    """

    def __init__(self, module, dist_kind: int, facet_kind: int, facet_variant: int, device: str = "cpu"):
        if device not in DEVICES:
            raise ValueError(f"device = {device!r}: accepted: {', '.join(map(repr, DEVICES))}")
        self.name = module.NAME
        self.tallies = module.TALLIES
        self.stats = module.STATS
        self.device = device
        self._key = (walk_registry.kind_of(module.NAME), dist_kind, facet_kind, facet_variant)
        self._kernel = None if device == "cuda" else loop.build(*self._key)
        self._prepare, self._dist_kind = module.prepare_direction, dist_kind

    @property
    def kernel(self):
        """The compiled walk (class doc)."""
        if self._kernel is None:
            from vcavity.kernels import cuda_loop  # numba-cuda is optional: loaded only for a GPU run

            self._kernel = cuda_loop.build_cuda(*self._key)
        return self._kernel

    @kernel.setter
    def kernel(self, kernel) -> None:  # a stand-in (tests)
        self._kernel = kernel

    @property
    def compiled(self) -> bool:
        """Whether the walk is compiled (or loaded from the cache) in this process."""
        if self.device == "cuda":
            return self._kernel is not None and self._kernel.launched
        return bool(self.kernel.walk.overloads)

    def device_attributes(self) -> dict:
        """What a table records of where the walk ran (docs/hdf5-format.md): ``device``, and
        for ``"cuda"`` the GPU's name and the CUDA driver's and runtime's versions."""
        if self.device == "cpu":
            return {"device": "cpu"}
        from vcavity.kernels import cuda_loop

        return {"device": self.device, **cuda_loop.device_attributes()}

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


def cuda_unavailable() -> str | None:
    """Why this process cannot run the CUDA kernels, or None when it can (a GPU and its
    driver, or numba's CUDA simulator); numba-cuda is imported here, only when asked
    (:func:`vcavity.simulate.plan.cuda_unavailable`).

    Returns
    -------
    str or None
        One phrase: numba-cuda is not installed, or no CUDA device or driver is found.
    """
    try:
        from vcavity.kernels import cuda_loop
    except ImportError:
        return "numba-cuda is not installed: pip install 'vcavity[cuda]'"
    if cuda_loop.SIMULATED or cuda_loop.cuda.is_available():
        return None
    return ("numba-cuda finds no CUDA device or driver here (numba.cuda.is_available() is False; "
            "the kernels need an NVIDIA GPU with a CUDA 13 driver)")


def get(name: str, dist_kind: int, facet_kind: int, facet_variant: int, device: str = "cpu") -> Walk:
    """The walk ``name`` for one scene (its kernel built once per process).

    Parameters
    ----------
    name : str
        A registered walk.
    dist_kind, facet_kind, facet_variant : int
        The scene: distribution and facet model (registry positions), facet variant.
    device : str
        ``"cpu"`` (the slot loop) or ``"cuda"`` (the CUDA kernel; needs numba-cuda, an
        unweighted walk and a GPU or the simulator: a run checks them first,
        :func:`vcavity.simulate.plan.check_device`).

    Raises
    ------
    KeyError
        An unknown walk (naming the registered ones).
    ValueError
        The walk cannot walk the distribution (:func:`vcavity.kernels.smith.walkable`); an
        unknown device; on ``"cuda"``, a weighted walk.
    ImportError
        On ``"cuda"``, numba-cuda is not installed.
    """
    module = walk_registry.get(name)
    reason = module.walkable(distributions.MODULES[distributions.REGISTRY.check_kind(dist_kind, "walks.get")].NAME)
    if reason is not None:
        raise ValueError(reason)
    return Walk(module, dist_kind, facet_kind, facet_variant, device)


__all__ = ["DEVICES", "Walk", "WalkCall", "cuda_unavailable", "get"]
