"""Dask gives the local table bit for bit: one cheap case in the default suite.

A LocalCluster of one worker process and a few work units of a small run, against the
same run traced locally with another chunking; a bug in how a work unit's blocks reach
the worker (an offset of its first block, a unit lost or repeated) changes the counts.
The thorough cases (two workers, a target-error run, a killed worker) are in
tests/simulate/test_distributed.py, marked slow. Deterministic: equality, nothing statistical.
"""

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity.simulate.pipeline import Simulation

distributed = pytest.importorskip("distributed")

RAW = {"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
       "incidence": {"theta_i_deg": [30.0, 70.0], "paths": 5 * 4096 + 100},  # 6 blocks, the last short
       "simulation": {"seed": 8, "max_order": 2, "sensor_resolution": 15}}


def test_one_worker_dask_run_equals_local_run_bit_for_bit():
    from vcavity.simulate.dask import DaskExecutor

    cfg = config_mod.validate(RAW)
    local = Simulation(cfg, chunk_blocks=4).run()
    with DaskExecutor("local:1") as executor:
        remote = Simulation(cfg, chunk_blocks=2).run(executor=executor)  # 3 units per direction
    for name in local.datasets:  # every dataset of the table
        np.testing.assert_array_equal(local[name], remote[name], err_msg=name)
    assert local["counts"].sum() > 0
