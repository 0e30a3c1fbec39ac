"""The slot loop on numba's CUDA target: one GPU thread per random-number block (docs/gpu.md).

The same walk as :mod:`vcavity.kernels.loop`, for the unweighted walks (the V-groove walk
and Smith's): a kernel closed over the same six integers as ``loop._make_loop`` (the walk,
whether it is weighted, the distribution, the facet model, the facet variant,
:data:`SOURCE_TAG <vcavity.kernels.scaffold.SOURCE_TAG>`), calling the same per-path tracer
(``registry.trace_path``), block streams (:func:`vcavity.kernels.scaffold.block_start`) and
binning (:func:`vcavity.sensor.binning.direction_to_cell`, which gives exactly the cell of
the CPU loop's ``bin_block``). numba-cuda compiles those jitted CPU functions as device
functions, and the registries' dispatch resolves the constant kinds as on the CPU: there
is one source of the physics, no second copy of any formula.

Thread ``t`` of the launch traces block ``first_block + t`` of the call, then ``t + G``,
``t + 2 G``, ... (grid-stride, ``G`` threads in the grid), each block from its own stream.
Exits go to ``counts[order slot, cell]`` by 64-bit integer atomic adds; the lost paths and
``unbinned`` to the statistics by atomic adds, ``max_bounces`` by an atomic max. Integer
atomics commute, so a table does not depend on the launch configuration or on how the
blocks are split over calls. It is not bit-equal to the CPU's: NVVM contracts ``a * b + c``
into FMAs and libdevice's transcendental functions are not glibc's (docs/gpu.md); under
the CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``), where the device functions are the CPU's
own compiled code, it is (tests/kernels/test_cuda_loop.py).

Each kernel is cached on disk (``cuda.jit(cache=True)``) in vcavity's Numba cache folder
(:mod:`vcavity._numba.jit`), one index per variant (named after it), keyed by numba-cuda on
the kernel's closure values (so on ``SOURCE_TAG``: an edit of any inlined source
recompiles), this file's time stamp, the argument types and the device's compute
capability: ``vcavity warmup --device cuda`` fills it, and a later process loads the
kernel instead of compiling it. Under the simulator nothing is compiled or cached.

numba-cuda is optional (``pip install vcavity[cuda]``): this module imports it at import
time, and nothing else in the package imports this module at import time.
"""

from __future__ import annotations

import numpy as np
from numba import config, cuda, float64, int64, uint64, void

from vcavity._numba import cache_lock
from vcavity._numba import jit as cache
from vcavity.kernels import registry as walks
from vcavity.kernels.loop import COLUMNS
from vcavity.kernels.scaffold import ABSORBED, EXITED, SOURCE_TAG, TRUNCATED, UNWEIGHTED, block_start
from vcavity.sensor.binning import direction_to_cell

if getattr(cuda, "implementation", None) != "NVIDIA":  # numba's own deprecated numba.cuda, not numba-cuda
    raise ImportError("the CUDA loop needs numba-cuda: pip install 'vcavity[cuda]'")

if not config.ENABLE_CUDASIM:  # (the simulator caches nothing)
    from numba.cuda.core import caching as _cuda_caching

    # numba-cuda's cache index is its own class, not Numba's: its saves made exclusive too
    # (two Dask workers on GPUs of two kinds save two entries of one kernel's index at once)
    cache_lock.install(cache.CACHE_LOCATION, _cuda_caching)

#: Whether numba runs CUDA kernels in its simulator (``NUMBA_ENABLE_CUDASIM=1``, read at import).
SIMULATED = bool(config.ENABLE_CUDASIM)

# the statistics columns the kernel adds to, by name (the CPU loop's order)
_ABSORBED, _TRUNCATED, _DEGENERATE, _MAX_BOUNCES, _UNBINNED = (
    COLUMNS.index(name) for name in ("absorbed", "truncated", "degenerate", "max_bounces", "unbinned"))
N_STATS = 5
#: CUDA's limit on the threads of a block.
MAX_THREADS_PER_BLOCK = 1024

#: The kernel's argument types, in order (the launch converts a call's fields to these).
SIGNATURE = void(float64, float64, float64, uint64, int64, int64, int64, float64[::1], float64[::1], int64, int64,
                 int64, int64, float64, float64, int64[:, ::1], int64[::1])

if SIMULATED:
    def host(array):
        """The simulator's array wrapper unwrapped: the device functions it calls are the CPU's
        compiled code, which cannot take the wrapper."""
        return getattr(array, "_ary", array)
else:
    @cuda.jit(device=True, forceinline=True)
    def host(array):
        """On the device: the array itself (folded away)."""
        return array


def _make_kernel(WALK, WEIGHTED, DIST, FACET, VARIANT, SOURCE_TAG):
    """The CUDA kernel of one unweighted walk and scene (module doc), for :func:`build_cuda`."""

    def kernel(ix, iy, iz, direction_key, first_block, n_blocks, n_paths, params, facet_data, max_bounces,
               max_order, resolution, first_binned_order, setup, weight_scale, counts, stats):
        # counts [max_order + 1, resolution**2] and stats [N_STATS]: the call's, zeroed, shared
        # by every thread (atomics only)
        _ = SOURCE_TAG  # part of a cache key, as in loop._make_loop
        _ = WEIGHTED  # always 0 here (build_cuda refuses weighted walks)
        walk_params = host(params)
        walk_data = host(facet_data)
        deepest = 0
        unbinned = 0
        absorbed = 0
        truncated = 0
        degenerate = 0
        for b in range(cuda.grid(1), n_blocks, cuda.gridsize(1)):
            state, n_here = block_start(direction_key, first_block, b, n_paths)
            for _path in range(n_here):
                # np.uint64: the simulator hands a CPU function's uint64 back as a Python int
                # (a no-op on the device)
                state, outcome, k, wx, wy, wz, q = walks.trace_path(
                    WALK, np.uint64(state), ix, iy, iz, setup, walk_params, DIST, FACET, VARIANT, walk_data,
                    max_bounces, weight_scale)
                if k > deepest:
                    deepest = k
                if outcome == EXITED:
                    if k < first_binned_order:
                        unbinned += 1
                    else:  # binned one exit at a time: a thread has no block of exits to vectorise
                        row = k if k <= max_order else 0
                        cuda.atomic.add(counts, (row, direction_to_cell(wx, wy, wz, resolution)), 1)
                elif outcome == UNWEIGHTED:  # (no unweighted walk returns it; the CPU loop's semantics)
                    unbinned += 1
                elif outcome == ABSORBED:
                    absorbed += 1
                elif outcome == TRUNCATED:
                    truncated += 1
                else:
                    degenerate += 1
        # one atomic per column and thread, after its blocks (a thread without blocks adds 0)
        cuda.atomic.add(stats, _ABSORBED, absorbed)
        cuda.atomic.add(stats, _TRUNCATED, truncated)
        cuda.atomic.add(stats, _DEGENERATE, degenerate)
        cuda.atomic.max(stats, _MAX_BOUNCES, deepest)
        cuda.atomic.add(stats, _UNBINNED, unbinned)

    return kernel


def arguments(call) -> tuple:
    """The kernel's scalar arguments and host arrays of a :class:`vcavity.kernels.walks.WalkCall`,
    of the types of :data:`SIGNATURE` (its ``n_slots`` unused: the threads are the launch's)."""
    ix, iy, iz = (float(v) for v in call.incident)
    return (ix, iy, iz, np.uint64(call.direction_key), int(call.first_block), int(call.n_blocks), int(call.n_paths),
            np.ascontiguousarray(call.params, np.float64), np.ascontiguousarray(call.facet_data, np.float64),
            int(call.max_bounces), int(call.max_order), int(call.resolution), int(call.first_binned_order),
            float(call.setup), float(call.weight_scale))


class CudaKernel:
    """One scene's walk as a CUDA kernel, called as :class:`vcavity.kernels.loop.SlotKernel` is.

    Called with a :class:`vcavity.kernels.walks.WalkCall` (``setup`` filled in, as
    :class:`vcavity.kernels.walks.Walk` does), it returns ``(counts, stats)`` of shapes
    ``[1, max_order + 1, resolution**2]`` and ``[1, 5]``, int64: the tallies of one slot row,
    the shapes ``SlotKernel`` gives for ``n_slots = 1``, whatever the call's ``n_slots``.

    Parameters
    ----------
    kernel : numba-cuda dispatcher
        The kernel (:func:`build_cuda`), compiled on its first launch.
    threads_per_block : int
        Threads of a CUDA block, the launch's default; no result depends on it.

    Attributes
    ----------
    launched : bool
        Whether it was launched (and so compiled, or loaded from the disk cache) in this process.
    """

    def __init__(self, kernel, threads_per_block: int = 128):
        self.kernel = kernel
        self.threads_per_block = _positive(threads_per_block, "threads_per_block", MAX_THREADS_PER_BLOCK)
        self.launched = False  # compiled, or loaded from the disk cache, on the first launch

    @property
    def compiles(self) -> int:
        """Times this process compiled the kernel (a load from the disk cache is none; 0
        under the simulator, which compiles nothing)."""
        stats = getattr(self.kernel, "stats", None)  # the simulator's kernels have none
        return 0 if stats is None else int(sum(stats.cache_misses.values()))

    @property
    def cache_path(self) -> str | None:
        """The folder of the kernel's disk cache (None: not cached, as under the simulator)."""
        stats = getattr(self.kernel, "stats", None)
        return None if stats is None or not stats.cache_path else str(stats.cache_path)

    def __call__(self, call) -> tuple:
        return self.launch(call)

    def launch(self, call, threads_per_block: int | None = None, blocks_per_grid: int | None = None) -> tuple:
        """Trace ``call``'s blocks with a given launch shape; returns ``(counts, stats)`` (class doc).

        Parameters
        ----------
        call : vcavity.kernels.walks.WalkCall
        threads_per_block : int, optional
            Default :attr:`threads_per_block`.
        blocks_per_grid : int, optional
            CUDA blocks of the grid; default enough for one thread per RNG block. Fewer make
            the threads loop over several RNG blocks (grid-stride); no result depends on it.
        """
        threads = self.threads_per_block if threads_per_block is None else _positive(
            threads_per_block, "threads_per_block", MAX_THREADS_PER_BLOCK)
        grid = max(1, -(-int(call.n_blocks) // threads)) if blocks_per_grid is None else _positive(
            blocks_per_grid, "blocks_per_grid")
        args = arguments(call)
        counts = cuda.to_device(np.zeros((int(call.max_order) + 1, int(call.resolution) ** 2), np.int64))
        stats = cuda.to_device(np.zeros(N_STATS, np.int64))
        # a launch even for a call without blocks: it compiles the kernel, as SlotKernel's slot 0 does
        self.kernel[grid, threads](*args[:7], cuda.to_device(args[7]), cuda.to_device(args[8]), *args[9:], counts,
                                   stats)
        self.launched = True
        return counts.copy_to_host()[None], stats.copy_to_host()[None]


def device_attributes() -> dict:
    """What a table records of the device that ran its walk (docs/hdf5-format.md).

    Returns
    -------
    dict of str to str
        ``device_name`` (the current GPU's name), ``cuda_driver_version`` and
        ``cuda_runtime_version`` (``"13.0"``); each ``"simulator"`` under numba's CUDA
        simulator, which has no device, driver or runtime.
    """
    if SIMULATED:
        return {"device_name": "simulator", "cuda_driver_version": "simulator", "cuda_runtime_version": "simulator"}
    from numba.cuda.cudadrv import driver

    name = cuda.get_current_device().name
    return {"device_name": name.decode() if isinstance(name, bytes) else str(name),
            "cuda_driver_version": ".".join(map(str, driver.driver.get_version())),
            "cuda_runtime_version": ".".join(map(str, cuda.runtime.get_version()))}


def launch_bytes(max_order: int, n_cells: int) -> int:
    """GPU memory one launch allocates: the tally ``[max_order + 1, n_cells]`` and the
    statistics, int64, with the parameter arrays (a few hundred bytes) rounded in."""
    return 8 * ((int(max_order) + 1) * int(n_cells) + N_STATS) + 4096


def free_memory() -> int | None:
    """Free memory of the current GPU, bytes (None under the simulator, which has no device)."""
    if SIMULATED:
        return None
    free, _total = cuda.current_context().get_memory_info()
    return int(free)


def _positive(value, name: str, most: int = 2 ** 31 - 1) -> int:
    """``value`` as an int in ``[1, most]``, or a one-line ValueError."""
    if isinstance(value, bool) or int(value) != value or not 1 <= value <= most:
        raise ValueError(f"{name} = {value!r}: must be an integer in [1, {most}]")
    return int(value)


def _kernel_function(walk_kind: int, dist_kind: int, facet_kind: int, facet_variant: int):
    """The kernel's Python function for one walk and scene, named after them (as loop.build names its walks)."""
    module = walks.MODULES[walks.REGISTRY.check_kind(walk_kind, "build_cuda")]
    if module.WEIGHTED:
        raise ValueError(f"walk {module.NAME!r} is weighted: the CUDA loop runs the unweighted walks only "
                         f"({', '.join(m.NAME for m in walks.MODULES if not m.WEIGHTED)})")
    if module.STATS != COLUMNS[:N_STATS]:
        raise ValueError(f"walk {module.NAME!r}: STATS must be the loop's columns {COLUMNS[:N_STATS]}, "
                         f"got {module.STATS}")
    function = _make_kernel(int(walk_kind), 0, int(dist_kind), int(facet_kind), int(facet_variant), SOURCE_TAG)
    function.__qualname__ = function.__name__ = (f"cuda_{module.__name__.rsplit('.', 1)[1]}_d{dist_kind}"
                                                 f"_f{facet_kind}_v{facet_variant}")
    return function


_KERNELS: dict[tuple[int, int, int, int], CudaKernel] = {}


def build_cuda(walk_kind: int, dist_kind: int, facet_kind: int, facet_variant: int) -> CudaKernel:
    """The CUDA kernel of walk ``walk_kind`` for one scene, built once per process.

    Parameters
    ----------
    walk_kind : int
        The walk's position in :mod:`vcavity.kernels.registry`; an unweighted walk.
    dist_kind, facet_kind, facet_variant : int
        The distribution and facet model (positions in their registries) and the facet's
        compiled variant.

    Returns
    -------
    CudaKernel
        Over ``cuda.jit(cache=True)`` of the kernel, compiled on its first launch or loaded
        from vcavity's cache folder (module doc; not cached where no folder is writable).

    Raises
    ------
    ValueError
        A weighted walk (one line naming it), or a kind out of range.
    """
    key = (int(walk_kind), int(dist_kind), int(facet_kind), int(facet_variant))
    if key not in _KERNELS:
        function = _kernel_function(*key)
        # cached like the CPU loop (jit.njit): numba-cuda reads the same numba.config.CACHE_DIR,
        # which jit sets to vcavity's folder while the decorator builds the cache locator
        _KERNELS[key] = CudaKernel(cache.cached(cuda.jit, function) if cache.CACHE_ENABLED else cuda.jit(function))
    return _KERNELS[key]


def ptx(walk_kind: int, dist_kind: int, facet_kind: int, facet_variant: int, cc: tuple[int, int]) -> str:
    """The PTX of one kernel for compute capability ``cc``, compiled without launching it.

    Where no CUDA driver is present, numba-cuda still asks the current device's compute
    capability when it compiles the kernel's callees; the tests stand in a device for it.

    Returns
    -------
    str
        PTX text.
    """
    text, _ = cuda.compile_ptx(_kernel_function(walk_kind, dist_kind, facet_kind, facet_variant), SIGNATURE,
                               cc=tuple(cc))
    return text


__all__ = ["CudaKernel", "N_STATS", "SIGNATURE", "SIMULATED", "arguments", "build_cuda", "device_attributes",
           "free_memory", "launch_bytes", "ptx"]
