"""Orchestration of a run: plan blocks per incident direction, call the walk chunk by
chunk, merge integer tallies, report progress. No physics here and no I/O.

Work is cut into RNG blocks of ``BLOCK_SIZE`` paths (see :mod:`vcavity.rng`); a chunk is a
run of consecutive blocks handed to one walk call, sized by time unless fixed
(:mod:`vcavity.simulate.chunking`). Neither the chunk size nor the thread count changes a
table: each block owns its random stream and counts are integers.
What is traced and what the table holds is the estimator's (:mod:`vcavity.estimators`):
its walk, the tally planes and statistics it keeps, its models and its values.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from vcavity.analytic.batches import ModelInterrupted
from vcavity.config import RunConfig
from vcavity.estimators import registry as estimators
from vcavity.estimators.counts import error_estimate_exists, relative_error
from vcavity.estimators.tabulate import tabulate
from vcavity.facet import registry as facets
from vcavity.io.schema import TableValue
from vcavity.kernels import walks
from vcavity.material import Material
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate import state as run_state
from vcavity.simulate.chunking import ChunkSizer
from vcavity.simulate.state import RunState

#: Target-error runs decide whether to stop after every this many blocks (about 2.6e5
#: paths): part of the definition of such a run, like BLOCK_SIZE (not tied to chunking).
TARGET_CHECK_BLOCKS = 64


@dataclass(frozen=True)
class Scene:
    """What the walk needs of a material, resolved through the registries once."""

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
    """A planned run: the estimator's walk compiled for the material, blocks per direction.

    Parameters
    ----------
    config : RunConfig
        The validated run.
    threads : int, optional
        Threads (default: all cores): the walk's slots, one thread each, and the analytic
        models' Numba threads. Does not change the result.
    chunk_blocks : int, optional
        RNG blocks per walk call; default sized to about half a second of work per call
        (a second on a GPU; :class:`vcavity.simulate.chunking.ChunkSizer`). Does not change
        the result.

    Attributes
    ----------
    estimator : module
        The run's estimator (:mod:`vcavity.estimators.registry`).
    models : object or None
        Its analytic models (exact-f1's cell models, exact's every-order models).
    walk : vcavity.kernels.walks.Walk or None
        The walk it traces (None: the estimator traces nothing, the models are the table).
    """

    def __init__(self, config: RunConfig, threads: int | None = None, chunk_blocks: int | None = None):
        self.config = config
        self.threads = int(threads) if threads else numba.config.NUMBA_NUM_THREADS
        if not 1 <= self.threads <= numba.config.NUMBA_NUM_THREADS:
            raise ValueError(f"threads = {threads}: must be in [1, {numba.config.NUMBA_NUM_THREADS}]")
        if chunk_blocks is not None and int(chunk_blocks) < 1:
            raise ValueError(f"chunk_blocks = {chunk_blocks}: must be >= 1")
        #: blocks per walk call (a fixed ``chunk_blocks``, else sized by time)
        self.chunks = ChunkSizer(chunk_blocks, device=config.device, n_slots=self.threads)
        self.estimator = estimators.get(config.estimator)
        self.scene = Scene.of(config.material)
        self.sensor = EqualAreaSensor(config.sensor_resolution)
        self.models = self.estimator.models(config, self.sensor)
        walk_name = self.estimator.walk(config.material)
        # an estimator without a walk traces nothing: no kernel is built or compiled; the
        # device picks the walk's loop (the CPU's slot loop, or the CUDA kernel)
        self.walk = None if walk_name is None else walks.get(walk_name, self.scene.dist_kind, self.scene.facet_kind,
                                                              self.scene.facet_variant, device=config.device)
        if self.walk is not None:
            unknown = sorted(set(self.estimator.TALLIES) - set(self.walk.tallies)) + sorted(
                set(self.estimator.STATS) - set(self.walk.stats))
            if unknown:
                raise ValueError(f"estimator {self.estimator.NAME!r} keeps {', '.join(unknown)}, which walk "
                                 f"{walk_name!r} does not give")
        self.compile_time_s = 0.0
        self.last_state: RunState | None = None  # the state of the last finished run
        self.workers_device: dict | None = None  # a cluster's GPUs ran the walk: what the table records of them

    @property
    def kernel(self):
        """The walk's compiled kernel (:class:`vcavity.kernels.loop.SlotKernel`, on CUDA
        :class:`vcavity.kernels.cuda_loop.CudaKernel`), or None."""
        return None if self.walk is None else self.walk.kernel

    @property
    def total_paths(self) -> int:
        """Paths planned: every direction's budget (with a target error, its cap; 0 without a walk)."""
        if self.walk is None:
            return 0
        return sum(self.config.path_budget(d) for d in self.config.incidence)

    def _call(self, incident, key, first_block: int, n_blocks: int, n_paths: int):
        c = self.config
        return self.walk(walks.WalkCall(
            incident=incident, direction_key=key, first_block=first_block, n_blocks=n_blocks, n_paths=n_paths,
            params=self.scene.params, facet_data=self.scene.facet_data, max_bounces=c.effective_max_bounces,
            max_order=c.max_order, resolution=c.sensor_resolution, n_slots=self.threads,
            first_binned_order=self.estimator.FIRST_BINNED_ORDER,
            weight_scale=getattr(self.estimator, "WEIGHT_SCALE", 0.0)))

    def compile(self) -> float:
        """Compile (or load from cache) the walk; return the seconds it took."""
        if self.walk is None:
            return 0.0
        t0 = time.perf_counter()
        numba.set_num_threads(self.threads)
        self._call(incident_vector(0.0, 0.0), np.uint64(0), 0, 0, 0)
        self.compile_time_s = time.perf_counter() - t0
        return self.compile_time_s

    def compile_models(self) -> float:
        """Compile (or load from the cache) the estimator's models' code on a tiny input;
        returns the seconds it took (0 without models, or when done already), which the
        table keeps apart from the model time (``model_compile_time_s``)."""
        if self.models is None:
            return 0.0
        numba.set_num_threads(self.threads)
        return self.models.compile()

    def prepare_models(self, should_stop: Callable[[], bool] | None = None) -> float:
        """The estimator's models, before any path is traced (compiled first when not yet,
        :meth:`compile_models`); returns their seconds (0 without), not counting the compile.

        Raises
        ------
        vcavity.analytic.single_bounce.ModelNotApplicable
            A model cannot reach the accuracy the run needs (one line).
        vcavity.analytic.batches.ModelInterrupted
            ``should_stop`` returned True (polled between the models' short compiled calls).
        """
        if self.models is None:
            return 0.0
        numba.set_num_threads(self.threads)
        return self.models.prepare(should_stop=should_stop)

    @property
    def model_time_s(self) -> float:
        """Seconds spent on the estimator's models (0 without)."""
        return 0.0 if self.models is None else self.models.time_s

    def execute(self, unit: WorkUnit):
        """Trace one work unit; returns its integer ``(tally, stats)`` summed over threads.

        ``tally[p, k]`` is the estimator's tally plane ``TALLIES[p]`` for order slot ``k``
        per cell (slot 0: beyond max_order); ``stats`` its ``STATS`` columns.
        """
        d = self.config.incidence[unit.direction]
        tallies, stats = self._call(incident_vector(d.theta_i, d.phi_i),
                                    direction_key(self.config.seed, d.theta_i, d.phi_i),
                                    unit.first_block, unit.n_blocks, self.config.path_budget(d))
        return (np.stack([tallies[name] for name in self.estimator.TALLIES]),
                np.array([stats[name] for name in self.estimator.STATS], dtype=np.int64))

    def _estimate(self, direction: int, tally, paths: int):
        return self.estimator.estimate(direction, tally, paths, self.config, self.sensor, self.models)

    def new_state(self) -> RunState:
        """The state of a run before its first path (:func:`vcavity.simulate.state.start`)."""
        return run_state.start(self.config, self.sensor.n_cells)

    def paths_done(self, state: RunState) -> np.ndarray:
        """Paths traced so far per direction."""
        return state.paths_done(self.config)

    def run(self, on_progress: Callable[..., None] | None = None, state: RunState | None = None,
            on_checkpoint: Callable[[RunState], None] | None = None, checkpoint_every_s: float = 60.0,
            should_stop: Callable[[], bool] | None = None, executor=None) -> TableValue:
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
            :class:`RunInterrupted` carrying the state (all finished chunks in it). The
            models poll it too: while they are prepared (a
            :class:`~vcavity.analytic.batches.ModelInterrupted`, nothing traced yet) and
            refined at the end (:class:`RunInterrupted` with the finished state).
        executor : callable, optional
            ``executor(simulation, units)`` -> iterable of ``(unit, execute(unit))`` in the
            order of ``units`` (an iterator, to be consumed lazily) (e.g. :class:`vcavity.simulate.dask.DaskExecutor`); default:
            execute them here, one after the other.
        """
        run_units = executor if executor is not None else _execute_here
        # an executor whose workers' GPUs run the walk (DaskExecutor.check_cuda): compiled there
        self.workers_device = getattr(executor, "device_attributes", None)
        if self.compile_time_s == 0.0 and self.workers_device is None:
            self.compile()
        self.prepare_models(should_stop)
        numba.set_num_threads(self.threads)
        state = state if state is not None else self.new_state()
        c = self.config
        t0 = time.perf_counter()
        start_compute = state.compute_time_s
        last_checkpoint = t0
        for j, d in enumerate(c.incidence):
            budget = c.path_budget(d)
            if j > 0 and not state.finished[j]:
                self.chunks.new_direction()
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
        try:
            return self.result(state, should_stop)
        except ModelInterrupted:  # while the models were refined: every path is in the state
            raise RunInterrupted(state) from None

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
        estimate = self._estimate(j, tally, paths)
        return relative_error(estimate, self.config.orders, self.sensor.cell_projected_solid_angle)

    def plan(self, j: int, state: RunState):
        """The work units of direction ``j`` from where ``state`` stands to its next check,
        in block order, each of :attr:`chunks`' size when it is drawn (generated lazily:
        budgets reach 2^62, and a unit's size follows the throughput of those before it)."""
        first = int(state.done_blocks[j])
        check = self._check_block(j, first)
        while first < check:
            n_blocks = min(self.chunks.blocks, check - first)
            yield WorkUnit(j, first, n_blocks)
            first += n_blocks

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
        _merge_stats(state.stats[j], unit_stats, self.estimator.STATS)
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
            landed = self.estimator.landed(state.tally[j], state.stats[j])
            if error_estimate_exists(landed, c.target_error) and \
                    self._direction_error(j, state.tally[j], paths) <= c.target_error:
                state.finished[j] = state.reached[j] = True

    def _current_error(self, j: int, state: RunState) -> float:
        if self.config.target_error is None:
            return math.nan
        paths = int(self.paths_done(state)[j])
        return self._direction_error(j, state.tally[j], paths)

    def result(self, state: RunState, should_stop: Callable[[], bool] | None = None) -> TableValue:
        """The table of a finished run state (its models refined to the counts first,
        ``should_stop`` polled meanwhile: :class:`~vcavity.analytic.batches.ModelInterrupted`)."""
        paths = self.paths_done(state)
        if self.models is not None:
            self.models.refine(state.tally, paths, should_stop=should_stop)
        reached = None
        if self.config.target_error is not None:  # a model's table: whether its mesh met the tolerance
            reached = state.reached.copy() if self.walk is not None else self.models.reached()
        compute_time_s = state.compute_time_s if self.walk is not None else self.model_time_s
        # a model's table is computed on the CPU, whatever the config's device
        device = {"device": "cpu"} if self.walk is None else self.workers_device or self.walk.device_attributes()
        return tabulate(self.config, self.sensor, self.estimator, state.tally, state.stats, paths, self.models,
                        reached, compute_time_s=compute_time_s, compile_time_s=self.compile_time_s,
                        block_size=BLOCK_SIZE, device=device)


def _execute_here(simulation: Simulation, units):
    """The local executor: each unit in turn, in this process (a generator, so a stop
    between units leaves the rest untraced); each call's time sizes the next."""
    for unit in units:
        t0 = time.perf_counter()
        outcome = simulation.execute(unit)
        simulation.chunks.observe(unit.n_blocks, time.perf_counter() - t0)
        yield unit, outcome


def _merge_stats(total: np.ndarray, part: np.ndarray, names) -> None:
    """Add a unit's statistics ``part`` to ``total`` in place: sums, but the deepest path's maximum."""
    for k, name in enumerate(names):
        total[k] = max(total[k], part[k]) if name == "max_bounces" else total[k] + part[k]


def _paths_in(first_block: int, n_blocks: int, budget: int) -> int:
    return min((first_block + n_blocks) * BLOCK_SIZE, budget) - min(first_block * BLOCK_SIZE, budget)


def simulate(config: RunConfig, threads: int | None = None, chunk_blocks: int | None = None,
             on_progress: Callable[..., None] | None = None) -> TableValue:
    """Run a whole config and return its table; see :class:`Simulation`."""
    sim = Simulation(config, threads=threads, chunk_blocks=chunk_blocks)
    return sim.run(on_progress)
