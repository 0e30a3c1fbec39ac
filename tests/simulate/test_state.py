"""Checkpoints: an interrupted and resumed run gives the uninterrupted table, bit for bit
(vcavity/simulate/state.py, vcavity/io/checkpoint.py, Simulation.run(state=..., should_stop=...)).

The interruption points are chosen by counting chunks, so the tests exercise stops inside
a direction, between directions and inside a target-error check interval.
"""

import h5py
import numpy as np
import pytest

from vcavity.io import checkpoint
from vcavity import config as config_mod
from vcavity.simulate import state as run_state
from vcavity.simulate.pipeline import RunInterrupted, Simulation

RAW = {"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
       "incidence": {"theta_i_deg": [20.0, 65.0], "paths": 300_000},
       "simulation": {"seed": 3, "max_order": 2, "sensor_resolution": 15}}


def _config(**simulation):
    return config_mod.validate({**RAW, "simulation": {**RAW["simulation"], **simulation}})


def _stop_after(n_chunks):
    calls = {"n": 0}

    def should_stop():
        calls["n"] += 1
        return calls["n"] >= n_chunks

    return should_stop


def _assert_same_table(a, b):
    for name in a.datasets:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


@pytest.mark.parametrize("simulation, stops", [
    ({}, [3]),                       # inside the first direction
    ({}, [5, 3, 4]),                 # three interruptions, one in the second direction
    ({"target_error": 0.03, "max_paths": 2_000_000}, [5, 7]),  # between target checks
])
def test_interrupt_save_load_resume_is_bitwise_identical(tmp_path, simulation, stops):
    cfg = _config(**simulation)
    whole = Simulation(cfg, chunk_blocks=7).run()
    state = None
    path = tmp_path / "run.h5.checkpoint"
    for n in stops:
        sim = Simulation(cfg, chunk_blocks=5 + n, threads=1 + n % 2)  # chunking and threads vary
        with pytest.raises(RunInterrupted) as info:
            sim.run(state=state, should_stop=_stop_after(n))
        run_state.save(path, info.value.state, cfg, sim.total_paths)
        state = run_state.load(path, cfg, layout=sim.new_state())
        np.testing.assert_array_equal(state.tally, info.value.state.tally)
    resumed = Simulation(cfg, chunk_blocks=3).run(state=state)
    _assert_same_table(whole, resumed)
    assert checkpoint.describe(path)["paths_done"] < sum(cfg.path_budget(d) for d in cfg.incidence)


def test_periodic_checkpoints_are_taken(tmp_path):
    cfg = _config()
    seen = []
    Simulation(cfg, chunk_blocks=4).run(on_checkpoint=lambda s: seen.append(s.done_blocks.copy()),
                                        checkpoint_every_s=0.0)
    assert len(seen) >= 5 and np.all(np.diff([b.sum() for b in seen]) > 0)


def test_a_corrupted_or_foreign_checkpoint_is_refused(tmp_path):
    cfg = _config()
    sim = Simulation(cfg, chunk_blocks=4)
    with pytest.raises(RunInterrupted) as info:
        sim.run(should_stop=_stop_after(3))
    path = tmp_path / "c.checkpoint"
    run_state.save(path, info.value.state, cfg, 2)
    good = path.read_bytes()
    with pytest.raises(checkpoint.CheckpointError, match="another run"):
        run_state.load(path, _config(seed=4))
    with h5py.File(path, "a") as h5:  # flip one count: the digest no longer matches
        tally = h5["tally"][()]
        tally.flat[np.argmax(tally)] += 1
        h5["tally"][...] = tally
    with pytest.raises(checkpoint.CheckpointError, match="corrupted"):
        run_state.load(path, cfg)
    path.write_bytes(good[: len(good) // 2])  # truncated
    with pytest.raises(checkpoint.CheckpointError, match="unreadable or truncated"):
        run_state.load(path, cfg)
    assert path.exists()  # never removed or replaced by the failed load
    with pytest.raises(checkpoint.CheckpointError, match="no checkpoint"):
        run_state.load(tmp_path / "missing", cfg)
    path.write_bytes(good)  # the same run, but a layout of other statistics columns is refused
    other = sim.new_state()
    other.stats = np.zeros((2, 8), np.int64)
    with pytest.raises(checkpoint.CheckpointError, match=r"stats of shape \(2, 5\), this run keeps \(2, 8\)"):
        run_state.load(path, cfg, layout=other)


def test_the_output_path_does_not_change_the_digest():
    a = _config().to_dict()
    b = dict(a, output={"path": "/elsewhere/x.h5"})
    assert checkpoint.config_digest(a) == checkpoint.config_digest(b)


@pytest.mark.parametrize("flags", [["--resume"], [], ["--overwrite"]])
def test_a_folder_at_the_checkpoint_path_is_refused_before_compiling(tmp_path, capsys, flags):
    """A folder at OUT.h5.checkpoint is no checkpoint: one line saying so (not "no
    checkpoint", not a failed save after compiling and tracing), exit 2, the folder kept."""
    from vcavity.cli import main

    config = tmp_path / "c.toml"
    config.write_text('[material]\ndistribution = "beckmann"\nalpha = 0.5\nkd = 0.5\n'
                      '[incidence]\ntheta_i_deg = [0]\npaths = 4096\n[simulation]\nsensor_resolution = 5\n')
    folder = tmp_path / "out.h5.checkpoint"
    folder.mkdir()
    (folder / "keep").write_text("mine")
    assert main(["run", str(config), "-o", str(tmp_path / "out.h5"), "-q", *flags]) == 2
    err = capsys.readouterr().err
    assert "kernel ready" not in err
    errors = [line for line in err.splitlines() if line.startswith("vcavity: error: ")]
    assert errors == [f"vcavity: error: checkpoint {str(folder)!r} is a folder, not a checkpoint: the run saves "
                      "its progress there; move it away or write the table elsewhere"]
    assert (folder / "keep").read_text() == "mine" and not (tmp_path / "out.h5").exists()
