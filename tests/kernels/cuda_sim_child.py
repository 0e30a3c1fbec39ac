"""Child process of tests/kernels/test_cuda_loop.py: the CUDA loop under numba's simulator.

Run with ``NUMBA_ENABLE_CUDASIM=1`` (read when numba.cuda is imported, so it must be set
before this process starts): ``python cuda_sim_child.py CASES_JSON``. For each case
(tests/kernels/cuda_cases.py) it prints one JSON line with the CPU walk's counts and
statistics and those of the CUDA loop under several launch shapes, a grid-stride launch
and the blocks split over two calls; the test compares them.
"""

import json
import os
import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from tests.kernels import cuda_cases  # noqa: E402

#: Launch shapes (threads per block, blocks per grid; None: one thread per RNG block).
LAUNCHES = {"tpb1": (1, None), "tpb2": (2, None), "stride": (1, 2)}


def run(spec: dict) -> dict:
    """The case's tables, CPU and simulated (module doc), as lists."""
    from vcavity.kernels import cuda_loop

    walk_kind, dist_kind, facet_kind, variant, _, _ = cuda_cases.scene(spec)
    kernel = cuda_loop.build_cuda(walk_kind, dist_kind, facet_kind, variant)
    call = cuda_cases.walk_call(spec)
    out = {"label": spec["label"], "n_blocks": call.n_blocks}
    counts, stats = cuda_cases.cpu_tables(spec)
    out["cpu"] = [counts.tolist(), stats.tolist()]
    for name, (threads, grid) in LAUNCHES.items():
        counts, stats = kernel.launch(call, threads_per_block=threads, blocks_per_grid=grid)
        out[name] = [counts[0].tolist(), stats[0].tolist()]
    parts = [kernel.launch(cuda_cases.walk_call(spec, 0, 1), threads_per_block=1),
             kernel.launch(cuda_cases.walk_call(spec, 1), threads_per_block=1)]
    counts, stats = cuda_cases.merged(parts)
    out["split"] = [counts.tolist(), stats.tolist()]
    return out


def main():
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1", "run under the CUDA simulator (NUMBA_ENABLE_CUDASIM=1)"
    # The simulator runs a CUDA block's threads as Python threads while its own thread polls
    # them without sleeping; at the default switch interval (5 ms) a block of two threads
    # ran up to 50 times slower than one of one thread, at 0.1 ms a few times at most.
    sys.setswitchinterval(1e-4)
    for spec in json.loads(sys.argv[1]):
        print(json.dumps(run(spec)), flush=True)


if __name__ == "__main__":
    main()
