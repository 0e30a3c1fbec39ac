"""Dask execution gives the local table bit for bit, also when a worker is killed mid-run;
two processes compiling one kernel into one cache at once do not corrupt it.

Slow: a LocalCluster of two worker processes starts in a few seconds, and each worker
loads (or, with a cold cache, compiles) the kernel.
"""

import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity.simulate.pipeline import Simulation

pytestmark = pytest.mark.slow
distributed = pytest.importorskip("distributed")

RAW = {"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
       "incidence": {"theta_i_deg": [30.0, 70.0], "paths": 400_000},
       "simulation": {"seed": 8, "max_order": 2, "sensor_resolution": 15}}


@pytest.fixture(scope="module")
def executor():
    from vcavity.simulate.dask import DaskExecutor

    with DaskExecutor("local:2") as running:
        yield running


def _same(a, b):
    for name in a.datasets:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_dask_run_equals_local_run(executor):
    cfg = config_mod.validate(RAW)
    local = Simulation(cfg, chunk_blocks=9).run()
    remote = Simulation(cfg, chunk_blocks=4).run(executor=executor)
    _same(local, remote)


def test_dask_smith_run_equals_local_run(executor):
    """The Smith walk (exact-f1, so its model too) on Dask workers: the local table bit for bit."""
    raw = {**RAW, "material": {**RAW["material"], "microsurface": "smith"},
           "simulation": {**RAW["simulation"], "estimator": "exact-f1"}}
    cfg = config_mod.validate(raw)
    local = Simulation(cfg, chunk_blocks=9).run()
    remote = Simulation(cfg, chunk_blocks=4).run(executor=executor)
    _same(local, remote)


def test_dask_target_error_run_equals_local_run(executor):
    cfg = config_mod.validate({**RAW, "simulation": {**RAW["simulation"], "target_error": 0.02,
                                                     "max_paths": 4_000_000}})
    _same(Simulation(cfg).run(), Simulation(cfg, chunk_blocks=8).run(executor=executor))


def test_a_killed_worker_changes_nothing(executor):
    cfg = config_mod.validate(RAW)
    local = Simulation(cfg).run()
    killed = []

    def killing(simulation, units):
        for n, result in enumerate(executor(simulation, units)):  # (unit, outcome) pairs
            if n == 3 and not killed:  # mid-run: other units are queued or running on it
                pid = sorted(executor.worker_pids().values())[0]
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            yield result

    remote = Simulation(cfg, chunk_blocks=2).run(executor=killing)
    assert killed
    _same(local, remote)


def test_two_processes_compiling_one_kernel_into_one_cache(tmp_path):
    """Both compile the same variant into an empty cache at the same moment; both succeed,
    and a third process then loads the kernel from that cache and gets the same counts."""
    script = textwrap.dedent("""
        import sys
        import numpy as np
        from vcavity import config as config_mod
        from vcavity.simulate.pipeline import simulate
        raw = {"material": {"distribution": "ggx", "alpha": 0.4, "facet": "mirror"},
               "incidence": {"theta_i_deg": [40.0], "paths": 50000},
               "simulation": {"seed": 2, "max_order": 2, "sensor_resolution": 9}}
        counts = simulate(config_mod.validate(raw))["counts"]
        print(int(counts.sum()), int(np.sum(counts * np.arange(counts.size).reshape(counts.shape))))
    """)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    processes = [subprocess.Popen([sys.executable, "-c", script], env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outputs = [p.communicate(timeout=600) for p in processes]
    for p, (out, err) in zip(processes, outputs):
        assert p.returncode == 0, err
    third = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600)
    assert third.returncode == 0, third.stderr
    assert outputs[0][0] == outputs[1][0] == third.stdout
    assert any((tmp_path / "cache").rglob("*.nbi"))  # the cache index was written
