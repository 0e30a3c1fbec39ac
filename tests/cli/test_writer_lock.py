"""One writer per output, through the real CLI (issue 38 item 1): a second ``vcavity sweep``
or ``vcavity run`` into a file another one is writing is refused in one line naming the
holder's pid and host, exit status 2, before it reads, writes or traces anything; the
first finishes and its file is its own. The lock file ``OUT.lock`` goes when its writer
ends (done, Ctrl-C, SIGTERM, an error); a ``kill -9`` leaves it, and the next writer takes
it over.

The first writer is stopped (SIGSTOP) while the second tries, so the test does not depend
on how fast either runs: the first provably still holds its lock, with its file or
checkpoint on disk. Runs use the beckmann + interfaced Lambertian variant the CLI tests
compile (9 x 9 cells). Nothing here is statistical: seeds tell the files apart.
"""

import hashlib
import json
import os
import signal
import socket
import subprocess
import sys
import time

import pytest

from vcavity import open_table
from vcavity.cli import main
from vcavity.io import checkpoint
from vcavity.io.lock import lock_path
from vcavity.io.sweep_table import open_sweep

MATERIAL = '[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 0.9\n'
SWEEP = (MATERIAL + "[incidence]\npaths = 1_000_000\n[simulation]\nseed = 17\nsensor_resolution = 9\n"
         "[sweep]\nalpha = [0.3, 0.6]\neta = [1.3, 1.5]\ntheta_i_deg = [0, 60]\n")
RUN = (MATERIAL + "alpha = 0.5\neta = 1.5\n[incidence]\ntheta_i_deg = [0, 60]\npaths = 4_000_000\n"
       "[simulation]\nseed = 17\nsensor_resolution = 9\n")


def _start(folder, *argv):
    return subprocess.Popen([sys.executable, "-m", "vcavity.cli", *argv, "-q"], cwd=folder, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def _wait_for(path, process, timeout=300):
    deadline = time.time() + timeout
    while not path.exists():
        assert process.poll() is None, process.communicate()
        assert time.time() < deadline, f"{path} never appeared"
        time.sleep(0.01)


def _holder_pid(output):
    return json.loads(lock_path(output).read_text())["pid"]


def _refused(folder, first, *argv):
    """Run a second writer while ``first`` holds the lock: it must be refused."""
    second = subprocess.run([sys.executable, "-m", "vcavity.cli", *argv, "-q"], cwd=folder, capture_output=True,
                            text=True, timeout=300)
    lines = second.stderr.strip().splitlines()
    assert second.returncode == 2, second.stderr
    assert len(lines) == 1 and second.stdout == "", second.stderr  # refused before anything else was said
    assert f"pid {first.pid} on host {socket.gethostname()}" in lines[0] and "lock file" in lines[0]
    return lines[0]


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_second_sweep_into_the_same_file_is_refused_and_the_first_completes(tmp_path):
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "two.h5"
    first = _start(tmp_path, "sweep", "s.toml", "-o", "two.h5")
    try:
        _wait_for(lock_path(out), first)
        os.kill(first.pid, signal.SIGSTOP)  # holds its lock, has written nothing yet (or its first point)
        assert _holder_pid(out) == first.pid
        before = _sha(out) if out.exists() else None
        line = _refused(tmp_path, first, "sweep", "s.toml", "-o", "two.h5", "--seed", "12")
        assert line.startswith("vcavity: error: --output = 'two.h5': is being written by another vcavity")
        assert (_sha(out) if out.exists() else None) == before
        os.kill(first.pid, signal.SIGCONT)
        _wait_for(out, first)  # its first point is written: the second now comes with --overwrite
        os.kill(first.pid, signal.SIGSTOP)
        assert _holder_pid(out) == first.pid and open_sweep(out).n_done() < 4, "the first sweep was already done"
        before = _sha(out)
        _refused(tmp_path, first, "sweep", "s.toml", "-o", "two.h5", "--seed", "12", "--overwrite")
        _refused(tmp_path, first, "sweep", "s.toml", "-o", "two.h5", "--resume")
        _refused(tmp_path, first, "sweep", "s.toml", "-o", "two.h5", "--overwrite", "--dask", "local:1")
        assert _sha(out) == before
    finally:
        os.kill(first.pid, signal.SIGCONT)
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    sweep = open_sweep(out)
    assert sweep.n_done() == 4 and int(sweep.attrs["seed"]) == 17 and json.loads(sweep.attrs["overrides"]) == {}
    assert not lock_path(out).exists()


@pytest.mark.parametrize("flag", [[], ["--resume"], ["--overwrite"], ["--overwrite", "--dask", "local:1"]],
                         ids=["plain", "resume", "overwrite", "dask"])
def test_a_second_run_is_refused_while_the_first_writes_its_checkpoint(tmp_path, flag):
    (tmp_path / "r.toml").write_text(RUN)
    out = tmp_path / "x.h5"
    first = _start(tmp_path, "run", "r.toml", "-o", "x.h5", "--checkpoint-every", "0.05", "--chunk-blocks", "8")
    try:
        _wait_for(checkpoint.checkpoint_path(out), first)
        os.kill(first.pid, signal.SIGSTOP)
        assert _holder_pid(out) == first.pid and not out.exists(), "the first run was already done"
        before = _sha(checkpoint.checkpoint_path(out))
        _refused(tmp_path, first, "run", "r.toml", "-o", "x.h5", "--seed", "3", *flag)
        assert _sha(checkpoint.checkpoint_path(out)) == before and not out.exists()
    finally:
        os.kill(first.pid, signal.SIGCONT)
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    assert open_table(out).seed == 17 and int(open_table(out).paths.sum()) == 8_000_000
    assert not checkpoint.checkpoint_path(out).exists() and not lock_path(out).exists()


@pytest.mark.parametrize("command,sent,status", [("run", signal.SIGINT, 130), ("run", signal.SIGTERM, 143),
                                                 ("sweep", signal.SIGINT, 130)])
def test_the_lock_goes_with_an_interrupted_writer(tmp_path, command, sent, status):
    (tmp_path / "r.toml").write_text(RUN)
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "o.h5"
    argv = (["run", "r.toml", "--checkpoint-every", "0.05", "--chunk-blocks", "8"] if command == "run"
            else ["sweep", "s.toml"])
    process = _start(tmp_path, *argv, "-o", "o.h5")
    _wait_for(lock_path(out), process)
    time.sleep(0.3)
    os.killpg(process.pid, sent)
    _, err = process.communicate(timeout=300)
    if process.returncode == 0:
        pytest.skip("the writer finished before the signal arrived")
    assert process.returncode == status and "Traceback" not in err, err
    assert not lock_path(out).exists()


def test_a_killed_writers_lock_is_taken_over_by_the_next(tmp_path):
    (tmp_path / "r.toml").write_text(RUN)
    out = tmp_path / "x.h5"
    first = _start(tmp_path, "run", "r.toml", "-o", "x.h5", "--checkpoint-every", "0.05", "--chunk-blocks", "8")
    _wait_for(checkpoint.checkpoint_path(out), first)
    os.killpg(first.pid, signal.SIGKILL)
    first.communicate()
    assert _holder_pid(out) == first.pid  # left behind by kill -9
    resumed = subprocess.run([sys.executable, "-m", "vcavity.cli", "run", "r.toml", "-o", "x.h5", "--resume", "-q"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert f"took over the stale lock file 'x.h5.lock' of pid {first.pid}" in resumed.stderr
    assert "resuming from" in resumed.stderr and open_table(out).seed == 17
    assert not lock_path(out).exists() and not checkpoint.checkpoint_path(out).exists()


def test_a_refusal_after_the_lock_was_taken_releases_it(tmp_path, monkeypatch):
    (tmp_path / "r.toml").write_text(RUN)
    monkeypatch.chdir(tmp_path)
    assert main(["run", "r.toml", "-o", "x.h5", "--threads", "4000", "-q"]) == 2  # refused after the lock
    assert not lock_path(tmp_path / "x.h5").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.toml"]
