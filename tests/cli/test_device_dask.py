"""``--dask`` with ``device = "cuda"``: each Dask worker runs its units on its own GPU
(docs/distributed.md, "Dask workers with GPUs").

- Refusal: workers that cannot run CUDA (no numba-cuda there, or no device: the workers of
  ``local:1`` are started with ``CUDA_VISIBLE_DEVICES=""``) are refused after connecting,
  before anything is compiled, traced or written: one line naming the device field as
  written and ``--dask``, exit status 2, for run and sweep.
- ``DaskExecutor.check_cuda`` against a stand-in client: the first worker that cannot,
  and the workers' GPUs joined for the table.
- A run whose executor's workers have GPUs compiles nothing here and records their GPUs.
- ``local:N`` on CUDA: one worker per GPU, each seeing its own (``CUDA_VISIBLE_DEVICES``;
  the workers' environment checked, no GPU needed); more workers than GPUs is refused.
- Under numba's CUDA simulator (child processes: numba reads ``NUMBA_ENABLE_CUDASIM`` at
  import; the ``local:2`` workers inherit it), ``run --device cuda --dask local:2`` writes
  the table of ``run --device cuda`` bit for bit (units of one block, merged in order).
"""

import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity import open_table
from vcavity.cli import main

from tests.cli.device_support import CONFIG, HAVE_NUMBA_CUDA, NO_DEVICE, NOT_INSTALLED

distributed = pytest.importorskip("distributed")

REASONS = (NOT_INSTALLED, NO_DEVICE)


@pytest.mark.parametrize("command, written", [("run", "flag"), ("run", "config"), ("sweep", "flag")])
def test_workers_that_cannot_run_cuda_are_refused(tmp_path, capsys, monkeypatch, command, written):
    monkeypatch.setenv("CUDA_VISIBLE_DEVICES", "")  # the workers see no GPU, even on a GPU machine
    path = tmp_path / "run.toml"
    path.write_text(CONFIG.format(simulation='device = "cuda"\n' if written == "config" else "")
                    + ("[sweep]\nalpha = [0.3, 0.6]\n" if command == "sweep" else ""))
    before = sorted(tmp_path.iterdir())
    status = main([command, str(path), "-o", str(tmp_path / "t.h5"), "-q", "--dask", "local:1",
                   *(["--device", "cuda"] if written == "flag" else [])])
    captured = capsys.readouterr()
    assert status == 2, captured.err
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    field = "--device" if written == "flag" else "simulation.device"
    prefix = f"vcavity: error: {field} = 'cuda': the Dask workers (--dask = 'local:1') cannot run it: worker tcp://"
    assert lines[0].startswith(prefix) and "(of 1): " in lines[0], lines[0]
    assert any(lines[0].split("(of 1): ", 1)[1].startswith(reason) for reason in REASONS), lines[0]
    assert sorted(tmp_path.iterdir()) == before


def _executor(answers):
    from vcavity.simulate.dask import DaskExecutor

    executor = DaskExecutor.__new__(DaskExecutor)  # no cluster: a stand-in client answers
    executor.client = SimpleNamespace(run=lambda function, needed: answers)
    executor.device_attributes = None
    return executor


def _gpu(name):
    return {"attributes": {"device_name": name, "cuda_driver_version": "13.0", "cuda_runtime_version": "13.0"}}


def test_check_cuda_names_the_worker_that_cannot_and_joins_the_gpus():
    executor = _executor({"tcp://b:2": _gpu("NVIDIA H100"), "tcp://a:1": _gpu("NVIDIA A100"),
                          "tcp://c:3": _gpu("NVIDIA H100")})
    executor.check_cuda(1000)
    assert executor.device_attributes == {"device": "cuda", "device_name": "NVIDIA A100, NVIDIA H100",
                                          "cuda_driver_version": "13.0", "cuda_runtime_version": "13.0"}
    bad = _executor({"tcp://a:1": _gpu("NVIDIA H100"), "tcp://b:2": {"error": "no room"}})
    with pytest.raises(ValueError, match=r"^worker tcp://b:2 \(of 2\): no room$"):
        bad.check_cuda(1000)
    assert bad.device_attributes is None
    with pytest.raises(ValueError, match="no Dask worker is connected"):
        _executor({}).check_cuda(1000)


def test_a_run_on_gpu_workers_compiles_nothing_here_and_records_their_gpus():
    """The executor's workers run the units (here: this process's CPU walk, as a stand-in)."""
    from vcavity.simulate.pipeline import Simulation

    class Workers:
        device_attributes = {"device": "cuda", "device_name": "NVIDIA A100, NVIDIA H100",
                             "cuda_driver_version": "13.0", "cuda_runtime_version": "13.0"}

        def __call__(self, simulation, units):
            for unit in units:
                yield unit, simulation.execute(unit)

    cfg = config_mod.validate({"material": {"distribution": "beckmann", "alpha": 0.5, "facet": "mirror"},
                               "incidence": {"theta_i_deg": [30.0], "paths": 100},
                               "simulation": {"max_order": 2, "sensor_resolution": 5}})
    simulation = Simulation(cfg, threads=1)
    compiled = []
    simulation.compile = lambda: compiled.append(1)
    table = simulation.run(executor=Workers())
    assert compiled == [] and table.attrs["compile_time_s"] == 0.0
    assert {key: table.attrs[key] for key in Workers.device_attributes} == Workers.device_attributes


FIELDS = ("counts", "brdf", "brdf_stderr", "albedo", "absorbed", "truncated", "degenerate", "paths",
          "max_bounces_seen", "unbinned_paths", "relative_error")


@pytest.mark.skipif(not HAVE_NUMBA_CUDA, reason="numba-cuda is not installed")
def test_a_simulated_cuda_run_on_dask_workers_writes_the_local_table(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text(CONFIG.format(simulation=""))
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    for name, flags in (("local.h5", []), ("dask.h5", ["--dask", "local:2", "--chunk-blocks", "1"])):
        out = subprocess.run([sys.executable, "-m", "vcavity", "run", str(path), "-o", str(tmp_path / name), "-q",
                              "--device", "cuda", *flags], env=env, capture_output=True, text=True, timeout=900)
        assert out.returncode == 0, out.stderr[-4000:]
    local, dask = open_table(tmp_path / "local.h5"), open_table(tmp_path / "dask.h5")
    assert local.counts.sum() > 0
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(dask, field), getattr(local, field), err_msg=field)
    assert dask.device == "cuda" and dask.attrs["device_name"] == "simulator"


@pytest.mark.skipif(not HAVE_NUMBA_CUDA, reason="numba-cuda is not installed")
@pytest.mark.gpu
def test_a_gpu_run_on_a_dask_worker_writes_the_local_gpu_table(tmp_path):
    """On a real device (skipped without one): ``local:1`` (one worker, the first GPU) gives
    the local GPU run's table bit for bit, and names the GPU."""
    from numba import cuda

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or not cuda.is_available():
        pytest.skip("no CUDA device")
    path = tmp_path / "run.toml"
    path.write_text(CONFIG.format(simulation=""))
    assert main(["run", str(path), "-o", str(tmp_path / "local.h5"), "-q", "--device", "cuda"]) == 0
    assert main(["run", str(path), "-o", str(tmp_path / "dask.h5"), "-q", "--device", "cuda", "--dask", "local:1",
                 "--chunk-blocks", "1"]) == 0
    local, dask = open_table(tmp_path / "local.h5"), open_table(tmp_path / "dask.h5")
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(dask, field), getattr(local, field), err_msg=field)
    assert dask.attrs["device_name"] == local.attrs["device_name"] != "simulator"


def test_a_local_gpu_cluster_gives_each_worker_its_own_gpu():
    """``local:N`` on CUDA: worker k sees only the k-th GPU (``CUDA_VISIBLE_DEVICES``); no GPU
    is needed to check the environment the workers start with."""
    from vcavity.simulate.dask import _gpu_cluster

    cluster = _gpu_cluster(["3", "5"], threads_per_worker=1, processes=True, dashboard_address=None,
                           scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
                           env={"NUMBA_NUM_THREADS": "1"})
    try:
        with distributed.Client(cluster) as client:
            client.wait_for_workers(2)
            assert sorted(client.run(os.getenv, "CUDA_VISIBLE_DEVICES").values()) == ["3", "5"]
            assert list(client.run(os.getenv, "NUMBA_NUM_THREADS").values()) == ["1", "1"]  # the other variables kept
            assert set(client.nthreads().values()) == {1}
    finally:
        cluster.close()


def test_more_local_workers_than_gpus_is_refused(monkeypatch):
    from vcavity.simulate import dask

    monkeypatch.setattr(dask, "_local_gpus", lambda: ["0"])
    with pytest.raises(ValueError, match=r"^with simulation.device = 'cuda', local:N starts one worker per GPU: N "
                                         r"must be from 1 to 1 \(the GPUs here\)$"):
        dask.DaskExecutor("local:2", device="cuda")
