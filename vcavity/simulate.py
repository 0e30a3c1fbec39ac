"""Orchestration of a run: plan blocks per incident direction, call the kernel chunk by
chunk, merge integer histograms, report progress. No physics here and no I/O.

Work is cut into RNG blocks of ``BLOCK_SIZE`` paths (see :mod:`vcavity.rng`); a chunk is a
run of consecutive blocks handed to one kernel call. Neither the chunk size nor the
thread count changes a table: each block owns its random stream and counts are integers.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from vcavity.config import Material, RunConfig
from vcavity.facet import registry as facets
from vcavity.kernels.trace import STAT_ABSORBED, STAT_DEGENERATE, STAT_MAX_BOUNCES, STAT_TRUNCATED, get_kernel
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor import EqualAreaSensor

#: Default paths per kernel call: large enough to amortise the call, small enough for a
#: lively progress bar (about a quarter of a second on 2 cores).
DEFAULT_CHUNK_BLOCKS = 512


@dataclass(frozen=True)
class Scene:
    """What the kernel needs of a material, resolved through the registries once."""

    dist_kind: int
    params: np.ndarray
    facet_kind: int
    facet_variant: int
    facet_data: np.ndarray

    @classmethod
    def of(cls, material: Material) -> "Scene":
        """Parameter arrays and compile-time constants of ``material``."""
        dist_kind, params = distributions.params_from(material.distribution, material.distribution_params)
        facet_kind, variant, data = facets.prepare(material.facet, material.facet_params)
        return cls(dist_kind, params, facet_kind, variant, data)


def incident_vector(theta_i: float, phi_i: float) -> np.ndarray:
    """Unit vector toward the light (physics.md sec. 1 conventions)."""
    s = math.sin(theta_i)
    return np.array([s * math.cos(phi_i), s * math.sin(phi_i), math.cos(theta_i)])


@dataclass
class RunResult:
    """Integer outcome of a run, per incident direction (ready for ``write_table``)."""

    theta_i: np.ndarray
    phi_i: np.ndarray
    order: np.ndarray
    counts: np.ndarray  # (incidence, order, cell) int64
    paths: np.ndarray
    absorbed_paths: np.ndarray
    truncated_paths: np.ndarray
    degenerate_paths: np.ndarray
    max_bounces_seen: np.ndarray
    sensor: EqualAreaSensor
    compute_time_s: float
    compile_time_s: float


class Simulation:
    """A planned run: the kernel for the material, blocks per direction.

    Parameters
    ----------
    config : RunConfig
        The validated run.
    threads : int, optional
        Numba threads (default: all cores). Does not change the result.
    chunk_blocks : int, optional
        RNG blocks per kernel call. Does not change the result.
    """

    def __init__(self, config: RunConfig, threads: int | None = None, chunk_blocks: int | None = None):
        self.config = config
        self.threads = int(threads) if threads else numba.config.NUMBA_NUM_THREADS
        if not 1 <= self.threads <= numba.config.NUMBA_NUM_THREADS:
            raise ValueError(f"threads = {threads}: must be in [1, {numba.config.NUMBA_NUM_THREADS}]")
        self.chunk_blocks = int(chunk_blocks) if chunk_blocks else DEFAULT_CHUNK_BLOCKS
        if self.chunk_blocks < 1:
            raise ValueError(f"chunk_blocks = {chunk_blocks}: must be >= 1")
        self.scene = Scene.of(config.material)
        self.sensor = EqualAreaSensor(config.sensor_resolution)
        self.kernel = get_kernel(self.scene.dist_kind, self.scene.facet_kind, self.scene.facet_variant)
        self.compile_time_s = 0.0

    @property
    def total_paths(self) -> int:
        return sum(d.paths for d in self.config.incidence)

    def _call(self, incident, key, first_block, n_blocks, n_paths):
        c = self.config
        return self.kernel(incident, key, first_block, n_blocks, n_paths, self.scene.params,
                           self.scene.facet_data, c.effective_max_bounces, c.max_order, c.sensor_resolution,
                           self.threads)

    def compile(self) -> float:
        """Compile (or load from cache) the kernel; return the seconds it took."""
        t0 = time.perf_counter()
        numba.set_num_threads(self.threads)
        self._call(incident_vector(0.0, 0.0), np.uint64(0), 0, 0, 0)
        self.compile_time_s = time.perf_counter() - t0
        return self.compile_time_s

    def run(self, on_progress: Callable[[int], None] | None = None) -> RunResult:
        """Trace every path of every direction; ``on_progress(paths_done_now)`` after each chunk."""
        if self.compile_time_s == 0.0:
            self.compile()
        numba.set_num_threads(self.threads)
        c = self.config
        n_inc = len(c.incidence)
        n_cells = self.sensor.n_cells
        slots = np.zeros((n_inc, c.max_order + 1, n_cells), np.int64)
        stats = np.zeros((n_inc, 4), np.int64)
        t0 = time.perf_counter()
        for d_index, d in enumerate(c.incidence):
            incident = incident_vector(d.theta_i, d.phi_i)
            key = direction_key(c.seed, d.theta_i, d.phi_i)
            n_blocks = -(-d.paths // BLOCK_SIZE)
            for first in range(0, n_blocks, self.chunk_blocks):
                n_here = min(self.chunk_blocks, n_blocks - first)
                counts, st = self._call(incident, key, first, n_here, d.paths)
                slots[d_index] += counts.sum(axis=0)
                stats[d_index, :3] += st[:, :3].sum(axis=0)
                stats[d_index, 3] = max(stats[d_index, 3], st[:, STAT_MAX_BOUNCES].max())
                if on_progress is not None:
                    on_progress(min((first + n_here) * BLOCK_SIZE, d.paths) - min(first * BLOCK_SIZE, d.paths))
        compute = time.perf_counter() - t0
        # order axis: 0 = all orders (f_inf, every slot), then 1..K
        if c.track_all_orders:
            counts = np.concatenate([slots.sum(axis=1, keepdims=True), slots[:, 1:]], axis=1)
        else:
            counts = slots[:, 1:].copy()
        return RunResult(
            theta_i=np.array([d.theta_i for d in c.incidence]),
            phi_i=np.array([d.phi_i for d in c.incidence]),
            order=np.array(c.orders, dtype=np.int64),
            counts=counts,
            paths=np.array([d.paths for d in c.incidence], dtype=np.int64),
            absorbed_paths=stats[:, STAT_ABSORBED].copy(),
            truncated_paths=stats[:, STAT_TRUNCATED].copy(),
            degenerate_paths=stats[:, STAT_DEGENERATE].copy(),
            max_bounces_seen=stats[:, 3].copy(),
            sensor=self.sensor,
            compute_time_s=compute,
            compile_time_s=self.compile_time_s,
        )


def simulate(config: RunConfig, threads: int | None = None, chunk_blocks: int | None = None,
             on_progress: Callable[[int], None] | None = None) -> RunResult:
    """Run a whole config; see :class:`Simulation`."""
    sim = Simulation(config, threads=threads, chunk_blocks=chunk_blocks)
    return sim.run(on_progress)
