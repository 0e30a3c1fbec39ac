"""scripts/bench_gpu.py where no GPU is: one line and exit 0 (issue 37 item 6), and, under the
CUDA simulator, its timing path runs every config and the two targets' albedos agree.

Deterministic except the slow test's albedo comparison: independent blocks of the same
direction on the two targets, |z| < 5 per order slot (false-positive rate below 3e-6 for
its 16 comparisons; the simulator runs the CPU's own device functions, so the two samples
come from one distribution).
"""

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "bench_gpu.py"


def test_without_a_gpu_one_line_and_exit_0():
    # under the simulator there is never a GPU to time, whether or not numba-cuda is installed
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    run = subprocess.run([sys.executable, str(SCRIPT), "--gpu-paths", "1e6"], env=env, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert len(lines) == 1 and lines[0].startswith("no GPU to time: "), run.stdout
    assert ("numba-cuda" in lines[0]) or ("simulator" in lines[0])
    assert run.stderr == ""


CHILD = """
import argparse, sys
sys.setswitchinterval(1e-4)  # the simulator's threads poll: a short switch interval keeps them moving
sys.path.insert(0, sys.argv[1])
import bench_gpu
args = argparse.Namespace(gpu_paths=3 * 4096, cpu_paths=4 * 4096, repeat=1, theta_deg=60.0)
for label, material in bench_gpu.CONFIGS:
    row = bench_gpu.bench_config(label, material, args)
    print(label, "|", row["gpu_rate"] > 0, row["cpu_rate"] > 0, row["albedo_max_abs_z"])
"""


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("numba_cuda") is None, reason="needs the cuda extra (numba-cuda)")
def test_timing_path_under_the_simulator(tmp_path):
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    run = subprocess.run([sys.executable, "-c", CHILD, str(SCRIPT.parent)], env=env, capture_output=True, text=True,
                         timeout=900, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    rows = [line.split(" | ") for line in run.stdout.splitlines() if " | " in line]
    assert len(rows) == 4, run.stdout
    for label, figures in rows:
        gpu_ok, cpu_ok, z = figures.split()
        assert gpu_ok == cpu_ok == "True", label
        assert float(z) < 5.0, (label, z)
