"""Child process of tests/cli/test_device_warmup.py: what only a fresh process can show.

``python cuda_warmup_child.py MODE [ARGS...]``, printing one JSON line:

- ``warmup ARGS...`` (under ``NUMBA_ENABLE_CUDASIM=1``, read when numba.cuda is imported):
  runs ``vcavity warmup ARGS...`` in this process; prints its exit status and which kernels
  it built and launched, CUDA and CPU (by their keys ``(walk, distribution, facet, variant)``).
- ``cache`` (without the simulator, no GPU needed: nothing is compiled): builds one CUDA
  kernel and prints the folder of its disk cache, vcavity's cache folder, and numba-cuda's
  cache index keys of the kernel's function made with this SOURCE_TAG and with another.
"""

import contextlib
import io
import json
import os
import sys
from pathlib import Path
from types import SimpleNamespace

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.insert(0, _ROOT)


def warmup(argv):
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1", "run under the CUDA simulator (NUMBA_ENABLE_CUDASIM=1)"
    sys.setswitchinterval(1e-4)  # the simulator's threads (tests/kernels/cuda_sim_child.py)
    from vcavity.cli import main
    from vcavity.kernels import cuda_loop, loop

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = main(["warmup", "-q", *argv])
    return {"status": status, "stderr": err.getvalue(),
            "cuda": sorted([list(key), kernel.launched] for key, kernel in cuda_loop._KERNELS.items()),
            "cpu_compiled": sorted(list(key) for key, kernel in loop._KERNELS.items() if kernel.walk.overloads)}


def cache():
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") != "1"
    from vcavity._numba import jit
    from vcavity.kernels import cuda_loop, scaffold

    kernel = cuda_loop.build_cuda(0, 0, 0, 0)
    codegen = SimpleNamespace(magic_tuple=lambda: ("nvptx64-nvidia-cuda", (9, 0), ""))  # as numba-cuda's
    keys = []
    for tag in (scaffold.SOURCE_TAG, scaffold.SOURCE_TAG + 1):
        function = cuda_loop._make_kernel(0, 0, 0, 0, 0, tag)
        function.__qualname__ = function.__name__ = "cuda_key_probe"
        dispatcher = jit.cached(cuda_loop.cuda.jit, function)
        keys.append(repr(dispatcher._cache._index_key(cuda_loop.SIGNATURE.args, codegen)))
    return {"cache_path": kernel.cache_path, "cache_location": jit.CACHE_LOCATION, "keys": keys}


if __name__ == "__main__":
    mode, *rest = sys.argv[1:]
    print(json.dumps(warmup(rest) if mode == "warmup" else cache()), flush=True)
