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

from vcavity.io.checkpoint import RunState
from vcavity.config import Material, RunConfig
from vcavity.estimators import (ANALOG, EXACT, EXACT_F1, PAPER, error_estimate_exists, estimate_direction,
                                estimate_weighted, mirror_cells, order_source, relative_error)
from vcavity.simulate.exact import ExactModels
from vcavity.simulate.f1_models import F1Models
from vcavity.facet import registry as facets
from vcavity.kernels import paper
from vcavity.kernels.smith import get_smith_kernel
from vcavity.kernels.trace import (N_STATS, STAT_ABSORBED, STAT_DEGENERATE, STAT_MAX_BOUNCES, STAT_TRUNCATED,
                                   STAT_UNBINNED, get_kernel)
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor

#: Default paths per kernel call: large enough to amortise the call, small enough for a
#: lively progress bar (about a quarter of a second on 2 cores).
DEFAULT_CHUNK_BLOCKS = 512
#: Target-error runs decide whether to stop after every this many blocks (about 2.6e5
#: paths): part of the definition of such a run, like BLOCK_SIZE (not tied to chunking).
TARGET_CHECK_BLOCKS = 64
#: Length of a work unit's statistics vector (see Simulation.execute).
N_TALLY_STATS = N_STATS + 3


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


@dataclass
class RunResult:
    """Outcome of a run, per incident direction (ready for ``write_table``).

    ``counts`` are the raw integer counts (never folded; with the exact-f1 estimator the
    first-order row is 0, those paths are in ``unbinned_paths``); ``brdf``,
    ``brdf_stderr`` and ``albedo`` are what the table tabulates
    (:mod:`vcavity.estimators`).
    """

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
    unbinned_paths: np.ndarray = None
    brdf: np.ndarray = None
    brdf_stderr: np.ndarray = None
    albedo: np.ndarray = None
    estimator: str = ANALOG
    order_source: np.ndarray = None
    folded: np.ndarray = None  # (incidence,) bool
    relative_error: np.ndarray = None  # (incidence,) energy-weighted, of f_inf (nan without it)
    target_reached: np.ndarray = None  # (incidence,) bool, target-error runs only
    model_time_s: float = 0.0
    model_error_ratio: float = 0.0  # largest model error / statistical error of a cell (exact-f1)
    block_size: int = BLOCK_SIZE
    lost_fractions: np.ndarray = None  # (incidence, 3) paper: weighted absorbed, truncated, degenerate


@dataclass(frozen=True)
class WorkUnit:
    """Consecutive RNG blocks of one incident direction: what one kernel call traces."""

    direction: int
    first_block: int
    n_blocks: int


class RunInterrupted(Exception):
    """A run stopped between chunks on request; ``state`` holds every finished chunk."""

    def __init__(self, state: "RunState"):
        super().__init__("run interrupted")
        self.state = state


class Simulation:
    """A planned run: the kernel for the material, blocks per direction.

    Parameters
    ----------
    config : RunConfig
        The validated run.
    threads : int, optional
        Threads (default: all cores): the kernel's slots, one thread each, and the analytic
        models' Numba threads. Does not change the result.
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
        self.weighted = config.estimator == PAPER
        self.exact = ExactModels(config, self.sensor, incident_vector) if config.estimator == EXACT else None
        build = (paper.get_paper_kernel if self.weighted
                 else get_smith_kernel if config.material.microsurface == "smith" else get_kernel)
        # the exact estimator traces nothing: no kernel is built or compiled
        self.kernel = None if self.exact else build(self.scene.dist_kind, self.scene.facet_kind,
                                                    self.scene.facet_variant)
        self.first_binned_order = 2 if config.estimator == EXACT_F1 else 1
        self.compile_time_s = 0.0
        self.f1_models = F1Models(config, self.sensor, incident_vector)  # exact-f1 only
        self.last_state: RunState | None = None  # the state of the last finished run

    @property
    def total_paths(self) -> int:
        """Paths planned: every direction's budget (with a target error, its cap; exact: 0)."""
        if self.exact:
            return 0
        return sum(self.config.path_budget(d) for d in self.config.incidence)

    def _call(self, incident, key, first_block, n_blocks, n_paths):
        c = self.config
        args = (incident, key, first_block, n_blocks, n_paths, self.scene.params, self.scene.facet_data,
                c.effective_max_bounces, c.max_order, c.sensor_resolution, self.threads)
        if self.weighted:
            return self.kernel(*args)
        return self.kernel(*args, self.first_binned_order)

    def compile(self) -> float:
        """Compile (or load from cache) the kernel; return the seconds it took."""
        if self.exact:
            return 0.0
        t0 = time.perf_counter()
        numba.set_num_threads(self.threads)
        self._call(incident_vector(0.0, 0.0), np.uint64(0), 0, 0, 0)
        self.compile_time_s = time.perf_counter() - t0
        return self.compile_time_s

    def prepare_models(self) -> float:
        """Exact-f1: every direction's f1 model before any path is traced
        (:meth:`vcavity.simulate.f1_models.F1Models.prepare`); 0 s for the other estimators.

        Raises
        ------
        vcavity.analytic.single_bounce.ModelNotApplicable
            The model cannot reach the accuracy the run needs (one line).
        """
        if self.exact:
            numba.set_num_threads(self.threads)
            return self.exact.prepare()
        if self.config.estimator != EXACT_F1:
            return 0.0
        return self.f1_models.prepare()

    @property
    def model_time_s(self) -> float:
        """Seconds spent on the exact-f1 or exact model (0 for the other estimators)."""
        return self.exact.time_s if self.exact else self.f1_models.time_s

    def _seen(self, state: RunState):
        """Per direction, the simulated cell counts of orders >= 2 (every slot)."""
        return [state.tally[j, 0].sum(axis=0).astype(np.float64) for j in range(len(self.config.incidence))]

    def execute(self, unit: WorkUnit) -> np.ndarray:
        """Trace one work unit; returns its integer tally summed over threads.

        ``tally[0, k]`` counts exits of order k per cell (slot 0: beyond max_order); the
        paper estimator adds ``tally[1]`` (Σ q) and ``tally[2]`` (Σ q^2). ``stats``:
        absorbed, truncated, degenerate paths, the deepest path, unbinned (or zero-weight)
        paths, then (paper) the weights absorbed, truncated and degenerate.
        """
        d = self.config.incidence[unit.direction]
        out = self._call(incident_vector(d.theta_i, d.phi_i), direction_key(self.config.seed, d.theta_i, d.phi_i),
                         unit.first_block, unit.n_blocks, self.config.path_budget(d))
        stats = np.zeros(N_TALLY_STATS, np.int64)
        if self.weighted:
            weights, squares, counts, st = out
            tally = np.stack([counts.sum(axis=0), weights.sum(axis=0), squares.sum(axis=0)])
            stats[[STAT_ABSORBED, STAT_TRUNCATED, STAT_DEGENERATE]] = st[:, [
                paper.PAPER_ABSORBED_PATHS, paper.PAPER_TRUNCATED_PATHS, paper.PAPER_DEGENERATE_PATHS]].sum(axis=0)
            stats[STAT_MAX_BOUNCES] = st[:, paper.PAPER_MAX_BOUNCES].max()
            stats[STAT_UNBINNED] = st[:, paper.PAPER_ZERO_WEIGHT].sum()
            stats[N_STATS:] = st[:, [paper.PAPER_ABSORBED, paper.PAPER_TRUNCATED, paper.PAPER_DEGENERATE]].sum(axis=0)
            return tally, stats
        counts, st = out
        stats[:N_STATS] = st.sum(axis=0)
        stats[STAT_MAX_BOUNCES] = st[:, STAT_MAX_BOUNCES].max()
        return counts.sum(axis=0)[None], stats

    def _estimate(self, direction: int, tally, paths: int):
        c = self.config
        counts = _table_counts(tally[0], c.track_all_orders)
        d = c.incidence[direction]
        mirror = mirror_cells(self.sensor, d.phi_i_deg) if c.folds(d) else None
        area = self.sensor.cell_projected_solid_angle
        if self.weighted:
            return counts, estimate_weighted(_table_counts(tally[1], c.track_all_orders),
                                             _table_counts(tally[2], c.track_all_orders), paths,
                                             paper.WEIGHT_SCALE, area, mirror=mirror)
        model = self.f1_models.of(direction)
        return counts, estimate_direction(counts, paths, c.orders, area, mirror=mirror,
                                          f1_integrals=model[0], f1_error=model[1])

    def new_state(self) -> RunState:
        """The state of a run before its first path (what a checkpoint stores)."""
        c = self.config
        n_inc = len(c.incidence)
        depth = 3 if self.weighted else 1
        return RunState(done_blocks=np.zeros(n_inc, np.int64), finished=np.zeros(n_inc, bool),
                        reached=np.zeros(n_inc, bool),
                        tally=np.zeros((n_inc, depth, c.max_order + 1, self.sensor.n_cells), np.int64),
                        stats=np.zeros((n_inc, N_TALLY_STATS), np.int64), compute_time_s=0.0)

    def paths_done(self, state: RunState) -> np.ndarray:
        """Paths traced so far per direction."""
        budgets = np.array([self.config.path_budget(d) for d in self.config.incidence], np.int64)
        return np.minimum(state.done_blocks * BLOCK_SIZE, budgets)

    def run(self, on_progress: Callable[..., None] | None = None, state: RunState | None = None,
            on_checkpoint: Callable[[RunState], None] | None = None, checkpoint_every_s: float = 60.0,
            should_stop: Callable[[], bool] | None = None, executor=None) -> RunResult:
        """Trace every direction; ``on_progress(paths_done_now, relative_error)`` after each chunk.

        With a target error each direction runs until the energy-weighted relative
        standard error of f_inf is at most the target or its budget is spent, decided
        from the counts after every ``TARGET_CHECK_BLOCKS`` blocks (absolute block
        counts), so the table depends neither on threads nor on chunking nor on where a
        run was interrupted and resumed.

        Parameters
        ----------
        state : RunState, optional
            Continue from a checkpoint (see :meth:`new_state`); it is updated in place.
        on_checkpoint : callable, optional
            Called with the state every ``checkpoint_every_s`` seconds, between chunks.
        should_stop : callable, optional
            Polled between chunks; when it returns True the run raises
            :class:`RunInterrupted` carrying the state (all finished chunks in it).
        executor : callable, optional
            ``executor(simulation, units)`` -> iterable of ``(unit, execute(unit))`` in the
            order of ``units`` (an iterator, to be consumed lazily) (e.g. :class:`vcavity.simulate.dask.DaskExecutor`); default:
            execute them here, one after the other.
        """
        run_units = executor if executor is not None else _execute_here
        if self.exact:  # nothing to trace: the models are the table
            self.prepare_models()
            state = state if state is not None else self.new_state()
            state.finished[:] = True
            self.last_state = state
            return self._exact_result()
        if self.compile_time_s == 0.0:
            self.compile()
        self.prepare_models()
        numba.set_num_threads(self.threads)
        state = state if state is not None else self.new_state()
        c = self.config
        t0 = time.perf_counter()
        start_compute = state.compute_time_s
        last_checkpoint = t0
        for j, d in enumerate(c.incidence):
            budget = c.path_budget(d)
            while not state.finished[j]:
                results = run_units(self, self.plan(j, state))
                for unit, outcome in results:
                    self.merge(state, unit, outcome)
                    now = time.perf_counter()
                    state.compute_time_s = start_compute + (now - t0)
                    if on_progress is not None:
                        on_progress(_paths_in(unit.first_block, unit.n_blocks, budget), self._current_error(j, state))
                    if on_checkpoint is not None and now - last_checkpoint >= checkpoint_every_s:
                        on_checkpoint(state)
                        last_checkpoint = time.perf_counter()
                    if should_stop is not None and not state.finished.all() and should_stop():
                        getattr(results, "close", lambda: None)()  # cancels what a cluster still runs
                        raise RunInterrupted(state)
        self.last_state = state
        return self.result(state)

    def _check_block(self, j: int, done: int) -> int:
        """The block count at which direction ``j`` is next checked: its end, or with a
        target error the next multiple of ``TARGET_CHECK_BLOCKS`` (absolute, so the same
        for any chunking and any resume point)."""
        n_blocks = -(-self.config.path_budget(self.config.incidence[j]) // BLOCK_SIZE)
        if self.config.target_error is None:
            return n_blocks
        return min(n_blocks, (done // TARGET_CHECK_BLOCKS + 1) * TARGET_CHECK_BLOCKS)

    def _direction_error(self, j: int, tally, paths: int) -> float:
        """The stop rule's measure for direction ``j``: relative error of f_inf (physics.md sec. 11)."""
        _, estimate = self._estimate(j, tally, paths)
        return relative_error(estimate, self.config.orders, self.sensor.cell_projected_solid_angle)

    def plan(self, j: int, state: RunState):
        """The work units of direction ``j`` from where ``state`` stands to its next check,
        in block order: ``chunk_blocks`` blocks each (generated lazily: budgets reach 2^62)."""
        done = int(state.done_blocks[j])
        check = self._check_block(j, done)
        return (WorkUnit(j, first, min(self.chunk_blocks, check - first)) for first in range(done, check, self.chunk_blocks))

    def merge(self, state: RunState, unit: WorkUnit, outcome) -> None:
        """Add a unit's outcome to ``state`` (units of a direction arrive in block order, so
        the state is always the tally of a prefix of its blocks), then apply the stop rule
        at a check block: the direction ends at its budget, or when the energy-weighted
        relative error of f_inf is at most the target."""
        j = unit.direction
        unit_tally, unit_stats = outcome
        if unit.first_block != state.done_blocks[j]:
            raise ValueError(f"unit {unit} merged out of order (done_blocks = {int(state.done_blocks[j])})")
        state.tally[j] += unit_tally
        deepest = max(state.stats[j, STAT_MAX_BOUNCES], unit_stats[STAT_MAX_BOUNCES])
        state.stats[j] += unit_stats
        state.stats[j, STAT_MAX_BOUNCES] = deepest
        done = unit.first_block + unit.n_blocks
        state.done_blocks[j] = done
        check = self._check_block(j, unit.first_block)
        if done != check:
            return
        c = self.config
        budget = c.path_budget(c.incidence[j])
        if done * BLOCK_SIZE >= budget:
            state.finished[j] = True
        if c.target_error is not None:
            paths = min(done * BLOCK_SIZE, budget)
            # a few landed paths give a binomial error of 0, not a small one: not reached
            landed = int(state.tally[j, 0].sum())
            if c.estimator == EXACT_F1:  # its first-order exits landed too (counted, not binned)
                landed += int(state.stats[j, STAT_UNBINNED])
            if error_estimate_exists(landed, c.target_error) and \
                    self._direction_error(j, state.tally[j], paths) <= c.target_error:
                state.finished[j] = state.reached[j] = True

    def _current_error(self, j: int, state: RunState) -> float:
        if self.config.target_error is None:
            return math.nan
        paths = int(self.paths_done(state)[j])
        return self._direction_error(j, state.tally[j], paths)

    def result(self, state: RunState) -> RunResult:
        """The tabulated outcome of a finished run state."""
        self.f1_models.refine(self._seen(state), self.paths_done(state))
        c = self.config
        n_inc = len(c.incidence)
        shape = (n_inc, len(c.orders), self.sensor.n_cells)
        counts, brdf, stderr = np.zeros(shape, np.int64), np.zeros(shape), np.zeros(shape)
        albedo = np.zeros((n_inc, len(c.orders)))
        error = np.full(n_inc, np.nan)
        paths = self.paths_done(state)
        stats = state.stats
        for j in range(n_inc):
            counts[j], estimate = self._estimate(j, state.tally[j], int(paths[j]))
            brdf[j], stderr[j], albedo[j] = estimate.brdf, estimate.brdf_stderr, estimate.albedo
            if c.track_all_orders:
                error[j] = relative_error(estimate, c.orders, self.sensor.cell_projected_solid_angle)
        return RunResult(
            theta_i=np.array([d.theta_i for d in c.incidence]),
            phi_i=np.array([d.phi_i for d in c.incidence]),
            order=np.array(c.orders, dtype=np.int64),
            counts=counts, paths=paths,
            absorbed_paths=stats[:, STAT_ABSORBED].copy(),
            truncated_paths=stats[:, STAT_TRUNCATED].copy(),
            degenerate_paths=stats[:, STAT_DEGENERATE].copy(),
            max_bounces_seen=stats[:, STAT_MAX_BOUNCES].copy(),
            unbinned_paths=stats[:, STAT_UNBINNED].copy(),
            sensor=self.sensor, compute_time_s=state.compute_time_s, compile_time_s=self.compile_time_s,
            brdf=brdf, brdf_stderr=stderr, albedo=albedo, estimator=c.estimator,
            order_source=order_source(c.orders, c.estimator),
            folded=np.array([c.folds(d) for d in c.incidence]),
            relative_error=error, target_reached=state.reached.copy() if c.target_error is not None else None,
            model_time_s=self.model_time_s, model_error_ratio=self.f1_models.error_ratio(self._seen(state), self.paths_done(state)),
            lost_fractions=stats[:, N_STATS:] / (paper.WEIGHT_SCALE * paths[:, None]) if self.weighted else None,
        )


    def _exact_result(self) -> RunResult:
        """The table of the exact estimator (:mod:`vcavity.simulate.exact`): no counts, no paths."""
        c = self.config
        n_inc = len(c.incidence)
        brdf, stderr, albedo, lost, error = self.exact.tabulated(c.orders)
        zeros = np.zeros(n_inc, np.int64)
        return RunResult(
            theta_i=np.array([d.theta_i for d in c.incidence]), phi_i=np.array([d.phi_i for d in c.incidence]),
            order=np.array(c.orders, dtype=np.int64), counts=np.zeros(brdf.shape, np.int64), paths=zeros,
            absorbed_paths=zeros, truncated_paths=zeros, degenerate_paths=zeros, max_bounces_seen=zeros,
            unbinned_paths=zeros, sensor=self.sensor, compute_time_s=self.exact.time_s, compile_time_s=0.0,
            brdf=brdf, brdf_stderr=stderr, albedo=albedo, estimator=EXACT,
            order_source=order_source(c.orders, EXACT), folded=np.zeros(n_inc, bool), relative_error=error,
            target_reached=None, model_time_s=self.exact.time_s, lost_fractions=lost)


def _execute_here(simulation: Simulation, units):
    """The local executor: each unit in turn, in this process (a generator, so a stop
    between units leaves the rest untraced)."""
    for unit in units:
        yield unit, simulation.execute(unit)


def _table_counts(slots, track_all_orders: bool):
    """The order axis of a table from kernel slots (slot 0 = beyond max_order):
    0 = every order (f_inf), then 1..K; without f_inf only 1..K."""
    if track_all_orders:
        return np.concatenate([slots.sum(axis=0, keepdims=True), slots[1:]], axis=0)
    return slots[1:].copy()


def _paths_in(first_block: int, n_blocks: int, budget: int) -> int:
    return min((first_block + n_blocks) * BLOCK_SIZE, budget) - min(first_block * BLOCK_SIZE, budget)


def simulate(config: RunConfig, threads: int | None = None, chunk_blocks: int | None = None,
             on_progress: Callable[..., None] | None = None) -> RunResult:
    """Run a whole config; see :class:`Simulation`."""
    sim = Simulation(config, threads=threads, chunk_blocks=chunk_blocks)
    return sim.run(on_progress)
