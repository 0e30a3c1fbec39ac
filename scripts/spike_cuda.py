"""Feasibility spike: the project's jitted walk on numba-cuda (issue "the walks on a GPU").

Runs each stage both as ``cuda.compile_ptx`` (no GPU, no driver needed with the shim
below) and, with ``--sim``, under the CUDA simulator (run the script with
``NUMBA_ENABLE_CUDASIM=1``). Prints OK or the error of each stage.

    NUMBA_CACHE_DIR=/tmp/c python scripts/spike_cuda.py [stage ...] [--cc 8.0] [--sim]

Stages: rng, sample, event, trace, loop.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
import traceback

import numpy as np

SIM = os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"

from numba import cuda, float64, int64, uint64  # noqa: E402

from vcavity.facet import registry as facets  # noqa: E402
from vcavity.kernels import registry as walks  # noqa: E402
from vcavity.microfacet import registry as distributions  # noqa: E402
from vcavity._numba.arrays import borrowed  # noqa: E402
from vcavity.kernels.scaffold import ABSORBED, EXITED, TRUNCATED, UNWEIGHTED, block_start  # noqa: E402
from vcavity.rng import BLOCK_SIZE, block_key, direction_key, next_uniform  # noqa: E402
from vcavity.sensor.binning import direction_to_cell  # noqa: E402

BECKMANN = distributions.kind_of("beckmann")
LAMBERT = facets.kind_of("interfaced_lambertian")
FACET_VALUES = facets.parse("interfaced_lambertian", facets.get("interfaced_lambertian").EXAMPLES["typical"])
VARIANT = facets.get("interfaced_lambertian").variant(FACET_VALUES)  # fig. 7b: the full variant
VGROOVE = walks.kind_of("v-cavity")


if SIM:
    def host(array):
        """The simulator hands kernels wrapped arrays, which CPU-jitted callees cannot unbox."""
        return getattr(array, "_ary", array)
else:
    from vcavity._numba.jit import njit

    @njit
    def host(array):
        """On the device: the array itself (an identity the compiler folds away)."""
        return array


@contextlib.contextmanager
def driverless(cc):
    """compile_ptx of a kernel that calls other dispatchers without a CUDA driver.

    numba-cuda compiles a called device function (and a CPU ``njit`` function, which it
    turns into one) for ``get_current_device().compute_capability``, which needs the
    driver even inside ``compile_ptx(..., cc=...)``. Stand in a device of ``cc``.
    """
    if SIM:
        yield
        return
    from numba.cuda import dispatcher as cuda_dispatcher

    class Device:
        compute_capability = cc

    saved = cuda_dispatcher.get_current_device
    cuda_dispatcher.get_current_device = lambda: Device()
    try:
        yield
    finally:
        cuda_dispatcher.get_current_device = saved


# ---------------------------------------------------------------- the kernels of each stage


def k_rng(out, key):
    i = cuda.grid(1)
    if i < out.size:
        state = np.uint64(block_key(key, i))  # np.uint64: the simulator hands back a Python int
        state, u = next_uniform(state)
        out[i] = u


def k_sample(out, key, params):
    i = cuda.grid(1)
    if i < out.shape[0]:
        state = np.uint64(block_key(key, i))  # np.uint64: the simulator hands back a Python int
        state, u1 = next_uniform(state)
        state, u2 = next_uniform(np.uint64(state))
        t, c, s = distributions.sample(BECKMANN, u1, u2, host(params))
        out[i, 0] = t
        out[i, 1] = c
        out[i, 2] = s


def k_event(out, key, data):
    i = cuda.grid(1)
    if i < out.shape[0]:
        state = np.uint64(block_key(key, i))  # np.uint64: the simulator hands back a Python int
        # a path going down onto a flat facet, cos_in = 1
        state, fate, dx, dy, dz = facets.event(LAMBERT, VARIANT, state, 0.0, 0.0, -1.0, 1.0, 0.0, 1.0, host(data))
        out[i, 0] = fate
        out[i, 1] = dx
        out[i, 2] = dy
        out[i, 3] = dz


def k_trace(out, key, params, data, ix, iy, iz, max_bounces):
    i = cuda.grid(1)
    if i < out.shape[0]:
        state = np.uint64(block_key(key, i))  # np.uint64: the simulator hands back a Python int
        state, outcome, k, wx, wy, wz, q = walks.trace_path(
            VGROOVE, state, ix, iy, iz, 0.0, host(params), BECKMANN, LAMBERT, VARIANT, host(data), max_bounces, 1)
        out[i, 0] = outcome
        out[i, 1] = k
        out[i, 2] = wx
        out[i, 3] = wy
        out[i, 4] = wz


def make_gpu_loop(WALK, DIST, FACET, VARIANT):
    """The slot loop of :mod:`vcavity.kernels.loop` as a CUDA kernel: one thread per RNG block.

    Thread ``b`` traces block ``first_block + b`` from its own stream
    (:func:`vcavity.kernels.scaffold.block_start`), path after path, with the same per-path
    tracer as the CPU loop (the registry's ``trace_path``, dispatched on constant kinds);
    each binned exit goes to ``counts[order slot, cell]`` by an int64 atomic add, the lost
    paths and ``unbinned`` to ``stats`` by atomic adds, ``max_bounces`` by an atomic max.
    Integer atomics commute, so the tallies do not depend on the launch configuration.
    Unweighted walks only (the weighted sums would be two more atomic planes).
    """

    def kernel(incident, direction_key, first_block, n_blocks, n_paths, params, facet_data, max_bounces,
               max_order, resolution, first_binned_order, setup, weight_scale, counts, stats):
        b = cuda.grid(1)
        if b >= n_blocks:
            return
        ix = incident[0]
        iy = incident[1]
        iz = incident[2]
        walk_params = host(params)
        walk_data = host(facet_data)
        state, n_here = block_start(direction_key, first_block, b, n_paths)
        deepest = 0
        unbinned = 0
        absorbed = 0
        truncated = 0
        degenerate = 0
        for _ in range(n_here):
            state, outcome, k, wx, wy, wz, q = walks.trace_path(
                WALK, np.uint64(state), ix, iy, iz, setup, walk_params, DIST, FACET, VARIANT, walk_data,
                max_bounces, weight_scale)
            if k > deepest:
                deepest = k
            if outcome == EXITED:
                if k < first_binned_order:
                    unbinned += 1
                else:
                    row = k if k <= max_order else 0
                    cuda.atomic.add(counts, (row, direction_to_cell(wx, wy, wz, resolution)), 1)
            elif outcome == UNWEIGHTED:
                unbinned += 1
            elif outcome == ABSORBED:
                absorbed += 1
            elif outcome == TRUNCATED:
                truncated += 1
            else:
                degenerate += 1
        cuda.atomic.add(stats, 0, absorbed)
        cuda.atomic.add(stats, 1, truncated)
        cuda.atomic.add(stats, 2, degenerate)
        cuda.atomic.max(stats, 3, deepest)
        cuda.atomic.add(stats, 4, unbinned)

    return kernel


k_loop = make_gpu_loop(VGROOVE, BECKMANN, LAMBERT, VARIANT)
LOOP_SIG = (float64[::1], uint64, int64, int64, int64, float64[::1], float64[::1], int64, int64, int64, int64,
            float64, float64, int64[:, ::1], int64[::1])


def k_borrowed(out, params):
    i = cuda.grid(1)
    if i < out.size:
        view = borrowed(params)
        out[i] = view[0]


STAGES = {
    "rng": (k_rng, (float64[::1], uint64)),
    "sample": (k_sample, (float64[:, ::1], uint64, float64[::1])),
    "event": (k_event, (float64[:, ::1], uint64, float64[::1])),
    "borrowed": (k_borrowed, (float64[::1], float64[::1])),
    "loop": (k_loop, LOOP_SIG),
    "trace": (k_trace, (float64[:, ::1], uint64, float64[::1], float64[::1], float64, float64, float64, int64)),
}


def scene():
    """Fig. 7b's scene: Beckmann alpha 0.5, interfaced Lambertian (kd 0.9, eta 1.5), full variant."""
    _, params = distributions.params_from("beckmann", distributions.parse("beckmann", {"alpha": 0.5}))
    facet = facets.get("interfaced_lambertian")
    return params, np.ascontiguousarray(facet.prepare(FACET_VALUES), np.float64), VARIANT, FACET_VALUES


def loop_call(params, data, n_paths, max_order=4, resolution=17):
    """A small call of fig. 7b's scene at theta_i = 0.3 (its blocks all in one call)."""
    from vcavity.kernels.walks import WalkCall

    theta = 0.3
    incident = np.array([np.sin(theta), 0.0, np.cos(theta)])
    n_blocks = -(-n_paths // BLOCK_SIZE)
    return WalkCall(incident=incident, direction_key=direction_key(1, theta, 0.0), first_block=0,
                    n_blocks=n_blocks, n_paths=n_paths, params=params, facet_data=data, max_bounces=100,
                    max_order=max_order, resolution=resolution, n_slots=1, first_binned_order=1)


def run_gpu_loop(call, threads_per_block=32):
    """``k_loop`` launched over the call's blocks: (counts, stats) as the CPU walk names them."""
    counts = np.zeros((call.max_order + 1, call.resolution ** 2), np.int64)
    stats = np.zeros(5, np.int64)
    grid = -(-call.n_blocks // threads_per_block)
    cuda.jit(k_loop)[grid, threads_per_block](
        call.incident, call.direction_key, call.first_block, call.n_blocks, call.n_paths, call.params,
        call.facet_data, call.max_bounces, call.max_order, call.resolution, call.first_binned_order, call.setup,
        call.weight_scale, counts, stats)
    return counts, stats


def simulate(name, params, data, key, n_paths):
    """Run stage ``name`` under the simulator (NUMBA_ENABLE_CUDASIM=1)."""
    if name == "loop":
        from vcavity.kernels import walks as walk_runs

        call = loop_call(params, data, n_paths)
        counts, stats = run_gpu_loop(call, threads_per_block=2)
        cpu_tallies, cpu_stats = walk_runs.get("v-cavity", BECKMANN, LAMBERT, VARIANT)(call)
        same = np.array_equal(counts, cpu_tallies["counts"]) and list(stats) == [cpu_stats[c] for c in
                                                                                 ("absorbed", "truncated",
                                                                                  "degenerate", "max_bounces",
                                                                                  "unbinned")]
        return (f"{call.n_paths} paths in {call.n_blocks} blocks; stats {stats.tolist()}, CPU {cpu_stats}; "
                f"{counts.sum()} binned exits; counts identical to the CPU walk's: {same}")
    n = 64
    cols = {"rng": None, "sample": 3, "event": 4, "trace": 5, "borrowed": None}[name]
    out = np.zeros(n) if cols is None else np.zeros((n, cols))
    extra = {"rng": (), "sample": (params,), "event": (data,), "trace": (params, data, 0.0, 0.0, 1.0, 100),
             "borrowed": ()}[name]
    if name == "borrowed":
        cuda.jit(k_borrowed)[2, 32](out, params)
    else:
        cuda.jit(STAGES[name][0])[2, 32](out, key, *extra)
    return f"first rows:\n{out[:3]}"


def main(argv=None):
    parser = argparse.ArgumentParser()
    parser.add_argument("stages", nargs="*", default=list(STAGES))
    parser.add_argument("--cc", default="8.0")
    parser.add_argument("--paths", type=int, default=3 * BLOCK_SIZE + 100, help="simulator loop stage")
    parser.add_argument("--ptx", help="folder to write each stage's PTX to")
    args = parser.parse_args(argv)
    cc = tuple(int(x) for x in args.cc.split("."))
    params, data, variant, values = scene()
    print(f"scene: beckmann params {params}, facet {facets.NAMES[LAMBERT]} {values} variant {variant}")
    key = direction_key(1, 0.3, 0.0)
    for name in args.stages:
        kernel, sig = STAGES[name]
        t0 = time.perf_counter()
        try:
            if SIM:
                result = simulate(name, params, data, key, args.paths)
                print(f"[{name}] simulator OK in {time.perf_counter() - t0:.1f}s; {result}")
            else:
                with driverless(cc):
                    ptx, _ = cuda.compile_ptx(kernel, sig, cc=cc)
                print(f"[{name}] compile_ptx cc={cc} OK in {time.perf_counter() - t0:.1f}s, {len(ptx)} chars PTX")
                if args.ptx:
                    os.makedirs(args.ptx, exist_ok=True)
                    with open(os.path.join(args.ptx, f"{name}_sm{cc[0]}{cc[1]}.ptx"), "w") as f:
                        f.write(ptx)
        except Exception as error:  # report and go on with the next stage
            print(f"[{name}] FAILED after {time.perf_counter() - t0:.1f}s: {type(error).__name__}: "
                  f"{str(error).splitlines()[0] if str(error) else ''}")
            traceback.print_exc(limit=-6, file=sys.stdout)


if __name__ == "__main__":
    main()
