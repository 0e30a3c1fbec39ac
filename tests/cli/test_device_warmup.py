"""``vcavity warmup --device cuda``: the CUDA kernels compiled into vcavity's disk cache (docs/gpu.md).

- Refusals: without numba-cuda (a stand-in makes its import fail) or without a CUDA
  device, one line naming ``--device``, exit status 2, nothing compiled.
- Under numba's CUDA simulator (a child process, tests/cli/cuda_warmup_child.py), the
  command builds and launches the selected variants' CUDA kernels and no CPU kernel, and
  says that the simulator caches nothing (caching itself needs a real device).
- Without a device (no simulator, nothing compiled): each kernel's cache is vcavity's
  folder, not numba's default, and its cache key changes with ``SOURCE_TAG`` (an edit of
  any source the kernel inlines recompiles it).
- ``gpu`` (skipped without a device): a second process loads what the first compiled.
"""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from vcavity.cli import main

from tests.cli.device_support import HAVE_NUMBA_CUDA

needs_numba_cuda = pytest.mark.skipif(not HAVE_NUMBA_CUDA,
                                      reason="numba-cuda is not installed (pip install 'vcavity[cuda]')")
CHILD = Path(__file__).with_name("cuda_warmup_child.py")
SELECTION = ["--distribution", "beckmann", "--facet", "mirror", "--microsurface", "v-cavity", "smith"]


def _child(args, env, timeout=600):
    out = subprocess.run([sys.executable, str(CHILD), *args], env=env, capture_output=True, text=True,
                         timeout=timeout)
    assert out.returncode == 0, out.stderr[-4000:]
    return json.loads(out.stdout.splitlines()[-1])


def _refused(capsys, argv) -> str:
    status = main(argv)
    captured = capsys.readouterr()
    assert status == 2, captured.err
    lines = captured.err.splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("vcavity: error: "), captured.err
    return lines[0][len("vcavity: error: "):]


def test_warmup_cuda_without_numba_cuda_is_refused(capsys, no_numba_cuda):
    assert _refused(capsys, ["warmup", "--device", "cuda", *SELECTION]) == \
        "--device = 'cuda': numba-cuda is not installed: pip install 'vcavity[cuda]'"


def test_warmup_cuda_without_a_device_is_refused(capsys, no_gpu):
    line = _refused(capsys, ["warmup", "--device", "cuda", *SELECTION])
    assert line.startswith("--device = 'cuda': numba-cuda finds no CUDA device or driver here"), line


def test_help_names_the_device_option(capsys):
    with pytest.raises(SystemExit):
        main(["warmup", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    for fact in ("--device {cpu,cuda}", "--device cuda compiles the variants' CUDA kernels", "Dask worker",
                 "weighted walk has no CUDA kernel"):
        assert fact in out, fact


@needs_numba_cuda
def test_simulated_warmup_builds_the_cuda_kernels_and_no_cpu_kernel():
    result = _child(["warmup", "--device", "cuda", *SELECTION], {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"})
    assert result["status"] == 0, result["stderr"]
    from vcavity.facet import registry as facets
    from vcavity.kernels import registry as walks
    from vcavity.microfacet import registry as distributions

    expected = [[[walks.kind_of(walk), distributions.REGISTRY.kind_of("beckmann"), facets.REGISTRY.kind_of("mirror"), 0],
                  True]
                for walk in ("v-cavity", "smith")]
    assert result["cuda"] == sorted(expected)
    assert result["cpu_compiled"] == []  # the CUDA kernels' device functions: not compiled for the CPU
    assert "2 variant(s) run under numba's CUDA simulator" in result["stderr"].splitlines()[-1]


@needs_numba_cuda
def test_the_kernels_cache_is_vcavitys_folder_and_keyed_by_the_source_tag(tmp_path):
    """In a process with no NUMBA_CACHE_DIR, vcavity's cache is the per-user folder; numba-cuda
    left to itself would cache beside the source (``__pycache__``) or nowhere."""
    env = {key: value for key, value in os.environ.items() if key not in ("NUMBA_CACHE_DIR", "NUMBA_ENABLE_CUDASIM")}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    result = _child(["cache"], env)
    assert result["cache_location"].startswith(str(tmp_path))
    assert result["cache_path"] is not None and result["cache_path"].startswith(result["cache_location"])
    this_tag, another_tag = result["keys"]
    assert this_tag != another_tag


@needs_numba_cuda
@pytest.mark.gpu
def test_a_second_process_loads_the_warmed_up_kernels(tmp_path):
    """On a real device: the first warmup compiles, the second (a new process) loads both."""
    from numba import cuda

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or not cuda.is_available():
        pytest.skip("no CUDA device")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    summaries = []
    for _ in range(2):
        out = subprocess.run([sys.executable, "-m", "vcavity", "warmup", "-q", "--device", "cuda", *SELECTION],
                             env=env, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-4000:]
        summaries.append(re.search(r"\((\d+) compiled, (\d+) loaded from the cache\)", out.stderr).groups())
    assert summaries == [("2", "0"), ("0", "2")]
