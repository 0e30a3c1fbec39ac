"""The memory preflight of a CUDA run (vcavity/simulate/plan.py, vcavity/io/preflight.py).

On ``device = "cuda"`` the host holds one tally set per kernel call, not one per CPU
thread: a run that needs more memory than is available with a tally per thread, and
less with one, is accepted on CUDA and refused on the CPU (the figures from
``run_memory_bytes``, tests/io/test_memory_estimate.py). Where a GPU is present its free
memory is checked against the launch's tally, ``(max_order + 1) x N^2`` int64 (a stand-in
reports the free memory), in one line naming the fields, exit status 2, for run and sweep.
"""

import importlib.util
import sys
from types import SimpleNamespace

import numba
import pytest

from vcavity import config as config_mod
from vcavity.cli import main
from vcavity.io import preflight
from vcavity.simulate import plan
from vcavity.simulate.plan import PlanError, RunRequest, plan_run

HAVE_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None
RAW = {"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
       "incidence": {"theta_i_deg": [30.0], "paths": 10_000},
       "simulation": {"seed": 1, "max_order": 30, "sensor_resolution": 40}}
THREADS = 64


@pytest.fixture
def cuda_here(monkeypatch):
    """This process as if it could run CUDA, with no device memory to check (numba-cuda
    not needed: the CUDA loop is a stand-in)."""
    import vcavity.kernels

    stand_in = SimpleNamespace(free_memory=lambda: None)
    monkeypatch.setattr(plan, "cuda_unavailable", lambda: None)
    monkeypatch.setitem(sys.modules, "vcavity.kernels.cuda_loop", stand_in)
    monkeypatch.setattr(vcavity.kernels, "cuda_loop", stand_in, raising=False)  # (imported by an earlier test)
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", THREADS)  # --threads 64 is accepted


def test_a_cuda_run_counts_one_tally_set_on_the_host(tmp_path, monkeypatch, cuda_here):
    n_orders = len(config_mod.validate(RAW).orders)
    one = preflight.run_memory_bytes(1, n_orders, 30, 40 * 40, threads=1)
    per_thread = preflight.run_memory_bytes(1, n_orders, 30, 40 * 40, threads=THREADS)
    assert per_thread > one + 1  # tracing dominates: the two estimates differ
    monkeypatch.setattr(preflight, "available_memory", lambda: one + 1)
    for device, accepted in (("cuda", True), ("cpu", False)):
        raw = {**RAW, "simulation": {**RAW["simulation"], "device": device}}
        request = RunRequest(config_mod.validate(raw), output=str(tmp_path / f"{device}.h5"), threads=THREADS)
        if accepted:
            assert plan_run(request).config.device == "cuda"
        else:
            with pytest.raises(PlanError, match=rf"\({THREADS} thread\(s\) x 31 orders x 1,600 cells per tally"):
                plan_run(request)


CONFIG = """\
[material]
distribution = "beckmann"
alpha = 0.6
kd = 0.9
eta = 1.5
[incidence]
theta_i_deg = [20]
paths = 5000
[simulation]
max_order = 15
sensor_resolution = 256
"""


@pytest.mark.skipif(not HAVE_NUMBA_CUDA, reason="numba-cuda is not installed")
@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_tally_larger_than_the_gpus_free_memory_is_refused(tmp_path, capsys, monkeypatch, command):
    from vcavity.kernels import cuda_loop

    monkeypatch.setattr(plan, "cuda_unavailable", lambda: None)
    tally = 16 * 256 ** 2 * 8  # 16 orders x 65,536 cells x 8 bytes: 8 MiB
    free = tally // 2
    monkeypatch.setattr(cuda_loop, "free_memory", lambda: free)
    monkeypatch.setattr(cuda_loop, "device_attributes", lambda: {"device_name": "Stand-in GPU"})
    path = tmp_path / "run.toml"
    path.write_text(CONFIG + ("[sweep]\nalpha = [0.3, 0.6]\n" if command == "sweep" else ""))
    status = main([command, str(path), "-o", str(tmp_path / "t.h5"), "-q", "--device", "cuda"])
    captured = capsys.readouterr()
    assert status == 2 and len(captured.err.splitlines()) == 1, captured.err
    assert captured.err.startswith("vcavity: error: simulation.sensor_resolution = 256 with max_order = 15: the "
                                   "GPU's tally needs about 8.00 MiB (16 orders x 65,536 cells), 4.00 MiB free on "
                                   "Stand-in GPU"), captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.toml"]
    monkeypatch.setattr(cuda_loop, "free_memory", lambda: 2 * tally)  # room: past the check
    assert plan.check_device_memory(config_mod.validate({**RAW, "simulation": {"device": "cuda", "max_order": 15,
                                                                               "sensor_resolution": 256}}), 256 ** 2) is None
