"""A sweep file records the device its walks ran on (root attribute ``device``, docs/sweeps.md),
and ``vcavity info`` prints it.

A CPU sweep in this process; a CUDA sweep under numba's simulator in a child process
(numba reads ``NUMBA_ENABLE_CUDASIM`` at import). Files written before the attribute read
their device from the overrides (``--device``) or the spec (``simulation.device``), else
``cpu``: tested by removing the attribute from the files just written.
"""

import contextlib
import importlib.util
import io
import os
import subprocess
import sys

import h5py
import pytest

from vcavity.cli import main
from vcavity.io.sweep_table import open_sweep

HAVE_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None

SWEEP = """\
[material]
distribution = "beckmann"
facet = "mirror"
[incidence]
theta_i_deg = [30]
paths = 300
[simulation]
seed = 5
max_order = 2
sensor_resolution = 5
{simulation}
[sweep]
alpha = [0.3, 0.6]
"""


def _info(path) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["info", str(path)]) == 0
    return out.getvalue()


def _without_attribute(path):
    with h5py.File(path, "r+") as h5:
        del h5.attrs["device"]


def _device_in_info(path) -> str:
    """The device ``vcavity info`` names on the line of the sweep's seed and estimator."""
    line = next(line for line in _info(path).splitlines() if line.startswith("points: "))
    return line.rsplit("; device ", 1)[1]


def test_a_cpu_sweep_records_cpu(tmp_path):
    spec = tmp_path / "sweep.toml"
    spec.write_text(SWEEP.format(simulation=""))
    out = tmp_path / "s.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q"]) == 0
    assert open_sweep(out).attrs["device"] == "cpu" and _device_in_info(out) == "cpu"
    _without_attribute(out)
    assert "device" not in open_sweep(out).attrs and _device_in_info(out) == "cpu"


@pytest.mark.skipif(not HAVE_NUMBA_CUDA, reason="numba-cuda is not installed")
@pytest.mark.parametrize("written", ["flag", "config"])
def test_a_simulated_cuda_sweep_records_cuda(tmp_path, written):
    spec = tmp_path / "sweep.toml"
    spec.write_text(SWEEP.format(simulation='device = "cuda"' if written == "config" else ""))
    out = tmp_path / "s.h5"
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    result = subprocess.run([sys.executable, "-m", "vcavity", "sweep", str(spec), "-o", str(out), "-q",
                             *(["--device", "cuda"] if written == "flag" else [])],
                            env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-4000:]
    sweep = open_sweep(out)
    assert sweep.attrs["device"] == "cuda" and sweep.n_done() == 2
    assert _device_in_info(out) == "cuda"
    _without_attribute(out)  # a file from before the attribute: the overrides or the spec say it
    assert _device_in_info(out) == "cuda"
