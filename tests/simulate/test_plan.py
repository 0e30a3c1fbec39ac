"""Planning a run (vcavity/simulate/plan.py): every refusal is one line naming the flag or
field, made before anything is compiled, and a plan records what the run needs.
Deterministic (no statistics)."""

from __future__ import annotations

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity.kernels import walks
from vcavity.simulate import state as run_state
from vcavity.simulate.plan import PlanError, RunRequest, plan_run

MIRROR = {"material": {"distribution": "ggx", "alpha": 0.4, "facet": "mirror"},
          "incidence": {"theta_i_deg": [20.0, 50.0], "paths": 8192},
          "simulation": {"sensor_resolution": 7}}


@pytest.fixture
def no_walk_built(monkeypatch):
    """Building a walk (and so compiling one) fails the test: planning builds none."""
    def refuse(*args):
        raise AssertionError("plan_run built a walk")

    monkeypatch.setattr(walks, "get", refuse)


def _request(tmp_path, simulation=None, **options):
    raw = {**MIRROR, "simulation": {**MIRROR["simulation"], **(simulation or {})}}
    return RunRequest(config_mod.validate(raw), output=str(tmp_path / "t.h5"), **options)


@pytest.mark.parametrize("simulation, options, words", [
    ({}, {"threads": 10**6}, "--threads = 1000000: must be between 1 and"),
    ({}, {"dask": "nowhere"}, "--dask = 'nowhere': not a scheduler address"),
    ({"estimator": "exact"}, {"dask": "local:1"}, "--dask = 'local:1': the exact estimator traces no path"),
    ({}, {"output": ""}, "--output = '': must be a file path"),
    ({"device": "cuda", "estimator": "paper"}, {},
     "simulation.device = 'cuda': the paper estimator runs on the CPU only: its walk is weighted"),
    ({"device": "cuda", "estimator": "paper"}, {"dask": "local:1"},
     "simulation.device = 'cuda': the paper estimator runs on the CPU only"),
    ({"device": "cuda", "estimator": "exact"}, {}, "simulation.device = 'cuda': the exact estimator traces no path"),
])
def test_refusals_are_one_line_and_build_no_walk(tmp_path, no_walk_built, simulation, options, words):
    request = _request(tmp_path, simulation)
    request = RunRequest(**{**request.__dict__, **options})
    with pytest.raises(PlanError) as info:
        plan_run(request)
    assert words in str(info.value) and "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_an_existing_checkpoint_is_resumed_only_when_asked_and_of_this_layout(tmp_path, no_walk_built):
    request = _request(tmp_path)
    plan = plan_run(request)
    assert plan.state is None and plan.config.output == (tmp_path / "t.h5").resolve()
    assert plan.total_paths == 2 * 8192 and plan.traces
    start = run_state.start(plan.config, 49)
    start.done_blocks[:] = 1
    path = tmp_path / "t.h5.checkpoint"
    run_state.save(path, start, plan.config, plan.total_paths)
    with pytest.raises(PlanError, match="checkpoint .* of an unfinished run exists: --resume to continue it"):
        plan_run(request)
    resumed = plan_run(RunRequest(**{**request.__dict__, "resume": True}))
    np.testing.assert_array_equal(resumed.state.done_blocks, [1, 1])
    assert resumed.resume_note.startswith("resuming from") and "8,192 of 16,384 paths done" in resumed.resume_note
    assert plan_run(RunRequest(**{**request.__dict__, "overwrite": True})).state is None  # afresh
    start.stats = np.zeros((2, 8), np.int64)  # the statistics of another layout
    run_state.save(path, start, plan.config, plan.total_paths)
    with pytest.raises(PlanError, match=r"holds stats of shape \(2, 8\), this run keeps \(2, 5\)"):
        plan_run(RunRequest(**{**request.__dict__, "resume": True}))


def test_a_model_table_traces_nothing_and_plans_no_paths(tmp_path, no_walk_built):
    plan = plan_run(_request(tmp_path, {"estimator": "exact"}))
    assert not plan.traces and plan.total_paths == 0
    assert run_state.start(plan.config, 49).finished.all()  # nothing to trace: every direction done
