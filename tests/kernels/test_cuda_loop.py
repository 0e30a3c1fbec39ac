"""The CUDA slot loop (vcavity/kernels/cuda_loop.py), tested where there is no GPU.

- Simulator: numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, in a child process,
  tests/kernels/cuda_sim_child.py, since numba reads the variable when numba.cuda is
  imported) runs the kernel's Python body on threads and the device functions it calls,
  the tracer, the block streams and the binning, as the CPU's own compiled code. With the
  same streams the CUDA loop must then give the CPU walk's tables *exactly*: any
  difference is the loop's (a stream key, a block range, an order slot, a column, a lost
  update), not rounding. Also across launch shapes (threads per block, a grid-stride
  launch) and the blocks split over two calls.
- PTX: ``cuda.compile_ptx`` for compute capabilities 8.0 and 9.0, no driver needed (but
  a stand-in for the device numba-cuda asks about, :func:`device_of`).
- ``gpu``: on a real device, the GPU's tables against the CPU walk's by a two-sample
  chi-square, and bit for bit across launch configurations.

Skipped, with the reason, where numba-cuda is not installed (the README's install has
the dev extra only; ``.ci/run`` installs the cuda extra and runs this file).
"""

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from tests.kernels import cuda_cases  # noqa: E402

HAVE_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None
needs_numba_cuda = pytest.mark.skipif(not HAVE_NUMBA_CUDA,
                                      reason="numba-cuda is not installed (pip install 'vcavity[cuda]')")
CHILD = Path(__file__).with_name("cuda_sim_child.py")
LAUNCHES = ("tpb1", "tpb2", "stride", "split")  # the child's launch shapes and split (cuda_sim_child.py)


def _simulate(cases, timeout):
    """Run the child under the simulator on ``cases``; its results by label."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    out = subprocess.run([sys.executable, str(CHILD), json.dumps(cases)], env=env, capture_output=True, text=True,
                         timeout=timeout)
    assert out.returncode == 0, out.stderr[-4000:]
    return {result["label"]: result for result in map(json.loads, out.stdout.splitlines())}


def _assert_identical(spec, result):
    """Every launch of the simulated loop gave the CPU walk's counts and statistics."""
    cpu_counts, cpu_stats = (np.array(a) for a in result["cpu"])
    absorbed, truncated, degenerate, _, unbinned = cpu_stats
    assert cpu_counts.sum() + absorbed + truncated + degenerate + unbinned == spec["n_paths"]
    for launch in LAUNCHES:
        counts, stats = (np.array(a) for a in result[launch])
        np.testing.assert_array_equal(counts, cpu_counts, err_msg=f"{spec['label']}, {launch}: counts")
        np.testing.assert_array_equal(stats, cpu_stats, err_msg=f"{spec['label']}, {launch}: statistics")


@needs_numba_cuda
def test_simulated_loop_gives_the_cpu_walks_tables():
    """The default cases in one child process (one test, not one per case: under xdist each
    worker would start its own child)."""
    results = _simulate(cuda_cases.DEFAULT_CASES, timeout=900)
    for spec in cuda_cases.DEFAULT_CASES:
        result = results[spec["label"]]
        _assert_identical(spec, result)
        counts, stats = (np.array(a) for a in result["cpu"])
        assert result["n_blocks"] == 3 and (counts.sum(axis=1) > 0).sum() >= 2, spec["label"]
        # what each case is there for (cuda_cases.DEFAULT_CASES): absorption, truncation, an
        # unbinned first order and the orders beyond max_order in slot 0
        if spec["facet"] == "interfaced_lambertian":
            assert stats[0] > 0, spec["label"]
        if spec["walk"] == "smith":
            assert stats[1] > 0 and stats[3] == spec["max_bounces"], spec["label"]
        if spec["first_binned_order"] == 2:
            assert stats[4] > 0 and counts[0].sum() > 0 and counts[1].sum() == 0, spec["label"]


@needs_numba_cuda
@pytest.mark.slow
def test_simulated_loop_gives_the_cpu_walks_tables_for_every_variant():
    """Every walk x distribution x facet variant (the registries' first examples), one child."""
    cases = cuda_cases.all_cases()
    results = _simulate(cases, timeout=7200)
    assert sorted(results) == sorted(spec["label"] for spec in cases)
    for spec in cases:
        _assert_identical(spec, results[spec["label"]])


def test_the_slow_matrix_is_every_variant_warmup_compiles():
    """The slow tests' cases (every walk x distribution x facet variant) are the variants of
    ``vcavity warmup``, read from the same registries."""
    from vcavity.simulate.warmup import variants

    expected = sorted(f"{v.microsurface}/{v.distribution}/{v.facet}/{v.facet_variant}".replace(" ", "_")
                      for v in variants())
    assert sorted(spec["label"] for spec in cuda_cases.all_cases()) == expected


@needs_numba_cuda
def test_the_loop_bins_with_the_cpu_loops_binning():
    """The kernel bins each exit with direction_to_cell, the function tests/sensor/test_binning.py
    checks against bin_block (the CPU loop's) on every kind of direction, cell for cell."""
    from vcavity.kernels import cuda_loop
    from vcavity.sensor import binning

    assert cuda_loop.direction_to_cell is binning.direction_to_cell
    assert "direction_to_cell(" in Path(cuda_loop.__file__).read_text()


@needs_numba_cuda
def test_a_weighted_walk_is_refused_in_one_line():
    from vcavity.kernels import cuda_loop
    from vcavity.kernels import registry as walks

    with pytest.raises(ValueError, match=r"^walk 'paper' is weighted: [^\n]*unweighted walks only") as error:
        cuda_loop.build_cuda(walks.kind_of("paper"), 0, 0, 0)
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="threads_per_block"):
        cuda_loop.CudaKernel(None, threads_per_block=0)


def test_nothing_in_the_package_imports_numba_cuda():
    """numba-cuda is optional: importing every other module of the package loads neither it
    nor the CUDA loop (a fresh process, so that only the package's own imports count)."""
    script = ("import importlib, pkgutil, sys, vcavity\n"
              "for info in pkgutil.walk_packages(vcavity.__path__, 'vcavity.'):\n"
              "    if info.name != 'vcavity.kernels.cuda_loop' and not info.name.endswith('__main__'):\n"
              "        importlib.import_module(info.name)\n"
              "print(sorted(name for name in sys.modules if name.startswith(('numba_cuda', 'numba.cuda', "
              "'vcavity.kernels.cuda_loop'))))\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True)
    assert out.stdout.strip() == "[]"


def test_editing_the_cuda_loop_recompiles_no_cpu_kernel():
    """The CPU kernels' source tag leaves the CUDA loop out: none of them inlines it."""
    from vcavity.kernels import scaffold

    names = {path.name for path in scaffold.source_files()}
    assert "cuda_loop.py" not in names and {"loop.py", "trace.py", "smith.py"} <= names


# ------------------------------------------------------------------------------ PTX


@pytest.fixture
def device_of(monkeypatch):
    """``device_of(cc)``: a stand-in for the device numba-cuda asks about when it compiles.

    numba-cuda compiles a kernel's callees (here the CPU's jitted functions, which it turns
    into device functions) for ``get_current_device().compute_capability``, a driver query,
    even inside ``compile_ptx(..., cc=...)``; without a driver that query raises. The
    stand-in answers ``cc``, so that callees and kernel are compiled for the same device.
    """
    from numba.cuda import dispatcher

    def stand_in(cc):
        monkeypatch.setattr(dispatcher, "get_current_device", lambda: SimpleNamespace(compute_capability=cc))

    return stand_in


def _check_ptx(device_of, spec, cc):
    from vcavity.kernels import cuda_loop

    walk_kind, dist_kind, facet_kind, variant, _, _ = cuda_cases.scene(spec)
    device_of(cc)
    text = cuda_loop.ptx(walk_kind, dist_kind, facet_kind, variant, cc)
    assert f".target sm_{cc[0]}{cc[1]}" in text
    assert ".visible .entry" in text
    assert ".extern" not in text  # every callee compiled into the module: nothing left to link
    assert "atom.global.add.u64" in text and "atom.global.max.s64" in text  # the tallies' atomics
    # the kernel writes global memory by atomics only: no plain store to it, global or generic
    # (a lost update, `counts[...] += 1`, is one; the simulator's threads would hardly race on it)
    stores = set(re.findall(r"\bst(?:\.[a-z]+)?\.(?:[usfb]\d+|v[24])", text))
    assert not {store for store in stores if not store.startswith(("st.local", "st.param", "st.shared"))}, stores


@needs_numba_cuda
@pytest.mark.parametrize("cc", [(8, 0), (9, 0)], ids=["sm80", "sm90"])
@pytest.mark.parametrize("spec", cuda_cases.DEFAULT_CASES, ids=lambda spec: spec["label"])
def test_the_kernel_compiles_to_ptx(device_of, spec, cc):
    _check_ptx(device_of, spec, cc)


@needs_numba_cuda
@pytest.mark.slow
@pytest.mark.parametrize("cc", [(8, 0), (9, 0)], ids=["sm80", "sm90"])
@pytest.mark.parametrize("spec", cuda_cases.all_cases(), ids=lambda spec: spec["label"])
def test_every_variant_compiles_to_ptx(device_of, spec, cc):
    _check_ptx(device_of, spec, cc)


# ------------------------------------------------------------------------------ a GPU


@pytest.fixture
def gpu():
    """Skips the test where no CUDA device is present (asked only by the tests that need one)."""
    from numba import cuda

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or not cuda.is_available():
        pytest.skip("no CUDA device")


#: Paths of the GPU-against-CPU test and of the launch test (module constants, so that a
#: smoke run under the simulator can make them small).
GPU_PATHS = 100_000_000
GPU_LAUNCH_PATHS = 10_000_000


def _homogeneity_p(a, b, min_count=20):
    """p-value of a two-sample chi-square (homogeneity) over categories: those with at
    least ``min_count`` in the two samples, and the rest pooled."""
    from vcavity.analytic.statistics import chi2_sf

    keep = a + b >= min_count
    table = np.array([np.append(a[keep], a[~keep].sum()), np.append(b[keep], b[~keep].sum())], np.float64)
    table = table[:, table.sum(axis=0) > 0]
    expected = table.sum(axis=1, keepdims=True) * table.sum(axis=0) / table.sum()
    return chi2_sf(float(((table - expected) ** 2 / expected).sum()), table.shape[1] - 1)


@needs_numba_cuda
@pytest.mark.gpu
@pytest.mark.slow
@pytest.mark.parametrize("spec", cuda_cases.DEFAULT_CASES, ids=lambda spec: spec["label"])
def test_gpu_tables_agree_with_the_cpu_walks(gpu, spec):
    """1e8 paths on the GPU and on the CPU, independent streams (two seeds): per (order slot,
    cell) and lost-path category, one multinomial. Rejects at a Sidak level of 1e-4 over the
    cases. Same streams would not do: the two would share most paths (not bit for bit, FMA
    contraction and libdevice) and the test would lose its power."""
    from vcavity.analytic.statistics import sidak_threshold
    from vcavity.kernels import cuda_loop

    spec = {**spec, "n_paths": GPU_PATHS}
    walk_kind, dist_kind, facet_kind, variant, _, _ = cuda_cases.scene(spec)
    gpu_counts, gpu_stats = cuda_loop.build_cuda(walk_kind, dist_kind, facet_kind, variant)(
        cuda_cases.walk_call(spec, key_seed=2))
    cpu_counts, cpu_stats = cuda_cases.cpu_tables(spec, n_slots=os.cpu_count() or 1)
    lost = [0, 1, 2, 4]  # absorbed, truncated, degenerate, unbinned
    p = _homogeneity_p(np.append(gpu_counts[0].ravel(), gpu_stats[0][lost]),
                       np.append(cpu_counts.ravel(), cpu_stats[lost]))
    assert p > sidak_threshold(1e-4, len(cuda_cases.DEFAULT_CASES))


@needs_numba_cuda
@pytest.mark.gpu
@pytest.mark.parametrize("spec", cuda_cases.DEFAULT_CASES, ids=lambda spec: spec["label"])
def test_gpu_tables_are_the_same_for_any_launch(gpu, spec):
    """1e7 paths: bit for bit across threads per block, a grid-stride launch (7 blocks of 64
    threads) and the blocks split over two calls."""
    from vcavity.kernels import cuda_loop

    spec = {**spec, "n_paths": GPU_LAUNCH_PATHS}
    kernel = cuda_loop.build_cuda(*cuda_cases.scene(spec)[:4])
    call = cuda_cases.walk_call(spec)
    half = call.n_blocks // 2
    first = kernel.launch(call, threads_per_block=256)
    for other in (kernel.launch(call, threads_per_block=32), kernel.launch(call, threads_per_block=64,
                                                                           blocks_per_grid=7),
                  cuda_cases.merged([kernel.launch(cuda_cases.walk_call(spec, 0, half)),
                                     kernel.launch(cuda_cases.walk_call(spec, half))])):
        np.testing.assert_array_equal(other[0].reshape(first[0].shape), first[0])
        np.testing.assert_array_equal(other[1].reshape(first[1].shape), first[1])

