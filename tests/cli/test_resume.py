"""`vcavity run` killed (SIGKILL) or interrupted (SIGINT) at arbitrary moments and resumed
with --resume writes the table of an uninterrupted run, bit for bit; the checkpoint is
always readable; `vcavity info` shows it as partial.

Processes start in their own process group (start_new_session), so SIGINT reaches them
as a terminal's Ctrl-C would. Moments are drawn from a seeded generator.
"""

import errno
import hashlib
import os
import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from vcavity import open_table
from vcavity.cli import main
from vcavity.io import checkpoint, writer

CONFIG = """
[material]
distribution = "beckmann"
alpha = 0.6
kd = 0.9
[incidence]
theta_i_deg = [30, 65]
paths = {paths}
[simulation]
seed = 4
sensor_resolution = 21
"""
FIELDS = ("counts", "paths", "brdf", "brdf_stderr", "albedo", "absorbed", "truncated", "max_bounces_seen")


def _start(tmp_path, out, *extra, env=None, preexec_fn=None):
    return subprocess.Popen([sys.executable, "-m", "vcavity.cli", "run", str(tmp_path / "run.toml"), "-o", str(out),
                             "-q", "--chunk-blocks", "8", "--checkpoint-every", "0.05", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env=env, preexec_fn=preexec_fn)


def _finish(process, timeout=600):
    out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err


def _same_tables(a, b):
    ta, tb = open_table(a), open_table(b)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(ta, name), getattr(tb, name), err_msg=name)


@pytest.fixture
def setup(tmp_path):
    def make(paths):
        (tmp_path / "run.toml").write_text(CONFIG.format(paths=paths))
        reference = tmp_path / "reference.h5"
        code, _, err = _finish(_start(tmp_path, reference))
        assert code == 0, err
        return reference
    return make


def test_sigint_saves_a_checkpoint_and_resume_completes(tmp_path, setup):
    reference = setup(30_000_000)
    out = tmp_path / "out.h5"
    process = _start(tmp_path, out)
    deadline = time.time() + 120
    while not checkpoint.checkpoint_path(out).exists() and time.time() < deadline:
        time.sleep(0.02)
    time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)
    code, stdout, err = _finish(process)
    if code == 0:
        pytest.skip("the run finished before SIGINT arrived (machine too fast for this budget)")
    assert code == 130, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert "interrupted; checkpoint" in lines[-1] and "Traceback" not in err
    assert not out.exists() and checkpoint.checkpoint_path(out).exists()
    info = subprocess.run([sys.executable, "-m", "vcavity.cli", "info", str(checkpoint.checkpoint_path(out))],
                          capture_output=True, text=True)
    assert info.returncode == 0 and "paths done" in info.stdout and "of 60,000,000" in info.stdout
    # without --resume the checkpoint is not overwritten: one line, exit 2
    refused = _finish(_start(tmp_path, out))
    assert refused[0] == 2 and "--resume" in refused[2]
    code, _, err = _finish(_start(tmp_path, out, "--resume"))
    assert code == 0, err
    assert "resuming from" in err
    assert not checkpoint.checkpoint_path(out).exists()
    _same_tables(reference, out)


@pytest.mark.slow
def test_three_sigkills_then_resume_equals_an_uninterrupted_run(tmp_path, setup):
    reference = setup(150_000_000)  # ~10 s on 2 idle cores: long enough for three kills
    out = tmp_path / "out.h5"
    moments = random.Random(20261201)
    kills = 0
    for _ in range(3):
        process = _start(tmp_path, out, *(["--resume"] if kills else []))
        time.sleep(moments.uniform(0.8, 2.5))
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        if out.exists():  # this run finished before its kill: nothing left to resume
            break
        kills += 1
        path = checkpoint.checkpoint_path(out)
        if path.exists():  # never left unreadable, whenever the kill came
            checkpoint.describe(path)
    assert kills >= 2
    if not out.exists():
        code, _, err = _finish(_start(tmp_path, out, "--resume"))
        assert code == 0, err
    _same_tables(reference, out)
    leftovers = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert leftovers == [] or all(p.stat().st_size >= 0 for p in leftovers)


@pytest.mark.slow
def test_sigkill_during_compilation_then_resume(tmp_path, setup):
    """A cold cache: the kill lands while Numba compiles, before any checkpoint exists;
    --resume then says so and starts from the first path."""
    reference = setup(4_000_000)
    out = tmp_path / "out.h5"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cold-cache")}
    process = _start(tmp_path, out, env=env)
    time.sleep(3.0)
    os.killpg(process.pid, signal.SIGKILL)
    process.communicate()
    assert not checkpoint.checkpoint_path(out).exists()
    code, _, err = _finish(_start(tmp_path, out, "--resume", env=env))
    assert code == 0, err
    assert "no checkpoint" in err
    _same_tables(reference, out)


SMALL = CONFIG.format(paths=4096).replace("sensor_resolution = 21", "sensor_resolution = 9")


def _files(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


@pytest.fixture
def left_a_checkpoint(tmp_path, monkeypatch, capsys):
    """run.toml ran to its end, but the table write failed: out.h5.checkpoint holds the run."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run.toml").write_text(SMALL)
    (tmp_path / "other.toml").write_text(SMALL.replace("seed = 4", "seed = 5"))
    (tmp_path / "sweep.toml").write_text(SMALL.replace("theta_i_deg = [30, 65]", "") + "[sweep]\nalpha = [0.6]\n"
                                                                                      "theta_i_deg = [30]\n")
    assert main(["run", "other.toml", "-o", "other.h5", "-q"]) == 0
    assert main(["sweep", "sweep.toml", "-o", "sweep.h5", "-q"]) == 0
    assert main(["run", "run.toml", "-o", "own.h5", "-q"]) == 0

    def full(h5, values):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with monkeypatch.context() as patch:
        patch.setattr(writer, "_write_datasets", full)
        assert main(["run", "run.toml", "-o", "out.h5", "-q"]) == 2
    assert checkpoint.checkpoint_path(tmp_path / "out.h5").is_file()
    capsys.readouterr()
    return tmp_path


@pytest.mark.parametrize("placed, what", [("sweep.h5", "a sweep file"),
                                          ("other.h5", "a table of another run (its config or seed differs)"),
                                          ("run.toml", "not a vcavity table")])
def test_resume_replaces_only_its_own_table(left_a_checkpoint, capsys, placed, what):
    folder = left_a_checkpoint
    (folder / "out.h5").write_bytes((folder / placed).read_bytes())  # put there after the interruption
    before = _files(folder)
    assert main(["run", "run.toml", "-o", "out.h5", "-q", "--resume"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.splitlines() == [
        f"vcavity: error: --output = 'out.h5': exists and is {what}; --resume replaces only the table of this "
        "run: pass --overwrite to replace it"]
    assert _files(folder) == before
    # its own table (killed between the table's rename and the checkpoint's removal) it replaces
    (folder / "out.h5").write_bytes((folder / "own.h5").read_bytes())
    assert main(["run", "run.toml", "-o", "out.h5", "-q", "--resume"]) == 0
    assert "resuming from out.h5.checkpoint" in capsys.readouterr().err
    assert not checkpoint.checkpoint_path(folder / "out.h5").exists()
    _same_tables(folder / "own.h5", folder / "out.h5")


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # as a non-interactive shell starts `cmd &`


@pytest.mark.parametrize("sigint", ["default", "ignored"])
def test_sigterm_is_handled_as_ctrl_c_with_exit_143(tmp_path, sigint):
    """SIGTERM (a scheduler's or `kill`'s stop) ends a run as Ctrl-C does: the checkpoint is
    saved, one line says so, no temporary file is left, and the exit status is 143; also
    where SIGINT is ignored, as in a script's background job (issue 38: there the run was
    lost)."""
    (tmp_path / "run.toml").write_text(CONFIG.format(paths=30_000_000))
    out = tmp_path / "out.h5"
    process = _start(tmp_path, out, preexec_fn=_ignore_sigint if sigint == "ignored" else None)
    deadline = time.time() + 120
    while not checkpoint.checkpoint_path(out).exists() and time.time() < deadline:
        time.sleep(0.02)
    time.sleep(0.2)
    process.send_signal(signal.SIGTERM)  # to the process alone, as `kill PID` does
    code, _, err = _finish(process)
    if code == 0:
        pytest.skip("the run finished before SIGTERM arrived (machine too fast for this budget)")
    assert code == 143, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert "interrupted; checkpoint" in lines[-1] and "Traceback" not in err
    assert not out.exists() and checkpoint.checkpoint_path(out).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5.checkpoint", "run.toml"]  # no temporary file
    info = subprocess.run([sys.executable, "-m", "vcavity.cli", "info", str(checkpoint.checkpoint_path(out))],
                          capture_output=True, text=True)
    assert info.returncode == 0 and "paths done" in info.stdout
