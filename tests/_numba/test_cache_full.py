"""A cache folder that cannot take a save (vcavity/_numba/cache_lock.py, issue 38).

A full disk (ENOSPC) in Numba's cache save ended ``warmup`` and every compiling ``run``
with a 115-125 line traceback and no table. Now the compiled code runs from memory, the
failure is one note on its own line, and errors that are not a refusing disk still raise.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.cli import test_faults

REPO = Path(__file__).resolve().parents[2]

# a child compiling one cached function, its saves failing with the errno given
CHILD = """
import errno, os, sys
sys.path.insert(0, sys.argv[2])
from numba.core import caching
plain = caching.IndexDataCacheFile.save
def failing(self, key, data):
    raise OSError(getattr(errno, sys.argv[1]), os.strerror(getattr(errno, sys.argv[1])))
caching.IndexDataCacheFile.save = failing
import vcavity._numba.jit  # installs the guard (and the index lock) for vcavity's cache folder
from vcavity._numba import cache_lock
import probe_module
print(probe_module.twice(21.0), len(cache_lock.SAVE_FAILURES))
"""
PROBE = """
from vcavity._numba.jit import njit

@njit(cache=True)
def twice(x):
    return 2.0 * x
"""


def _env(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    return {**env, "PYTHONPATH": str(REPO), "NUMBA_CACHE_DIR": str(tmp_path / "cache"), **extra}


@pytest.mark.parametrize("name", ["ENOSPC", "EROFS", "EDQUOT", "EACCES"])
def test_a_refused_save_is_one_note_and_the_code_runs(tmp_path, name):
    (tmp_path / "mod").mkdir()
    (tmp_path / "mod" / "probe_module.py").write_text(PROBE)
    child = subprocess.run([sys.executable, "-c", CHILD, name, str(tmp_path / "mod")], env=_env(tmp_path),
                           capture_output=True, text=True, timeout=300)
    assert child.returncode == 0, child.stderr
    assert child.stdout.split() == ["42.0", "1"]
    reason = os.strerror(getattr(__import__("errno"), name))
    assert child.stderr.splitlines() == [
        f"vcavity: note: the Numba cache folder {str(tmp_path / 'cache')!r} cannot take compiled code ({reason}): "
        f"compiling in this process only, the next run compiles again (free space there, or set NUMBA_CACHE_DIR "
        f"to a folder that can)"]


def test_other_errors_still_raise(tmp_path):
    """An I/O error that is not a refusing disk is not hidden."""
    (tmp_path / "mod").mkdir()
    (tmp_path / "mod" / "probe_module.py").write_text(PROBE)
    child = subprocess.run([sys.executable, "-c", CHILD, "EIO", str(tmp_path / "mod")], env=_env(tmp_path),
                           capture_output=True, text=True, timeout=300)
    assert child.returncode != 0 and "Input/output error" in child.stderr


small_disk = test_faults.small_disk  # the fixture: a 256 kB tmpfs (root only)


@pytest.fixture
def full_disk(small_disk):
    """That tmpfs with a cache folder, filled to the last byte: a real disk that is full."""
    (small_disk / "cache").mkdir()
    test_faults._leave_free(small_disk, 0)
    return small_disk


RUN = """[material]
distribution = "beckmann"
alpha = 0.3
facet = "mirror"
[incidence]
theta_i_deg = [20.0]
paths = 10000
[simulation]
seed = 1
max_order = 2
sensor_resolution = 6
"""


def test_a_run_on_a_full_cache_disk_writes_its_table(tmp_path, full_disk):
    """The issue's case on a real full disk: the kernel's save fails with ENOSPC; the run
    compiles in memory, writes its table, exit 0, and says so once on a line of its own
    (after the compile notice's line, not inside it)."""
    (tmp_path / "c.toml").write_text(RUN)
    env = _env(tmp_path, NUMBA_CACHE_DIR=str(full_disk / "cache"))
    done = subprocess.run([sys.executable, "-m", "vcavity", "run", "c.toml", "-o", "c.h5"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert (tmp_path / "c.h5").is_file()
    notes = [line for line in done.stderr.splitlines() if "cannot take compiled code" in line]
    assert len(notes) == 1 and notes[0].startswith(
        f"vcavity: note: the Numba cache folder {str(full_disk / 'cache')!r} cannot take compiled code "
        f"(No space left on device)"), done.stderr


def test_warmup_on_a_full_cache_disk_is_one_error_line(tmp_path, full_disk):
    """warmup's work is the saving: a refused save is its failure, exit 2, one line."""
    env = _env(tmp_path, NUMBA_CACHE_DIR=str(full_disk / "cache"))
    done = subprocess.run([sys.executable, "-m", "vcavity", "warmup", "--distribution", "beckmann", "--facet",
                           "mirror", "-q"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"vcavity: error: the Numba cache folder {str(full_disk / 'cache')!r} cannot take compiled code "
        f"(No space left on device): "), done.stderr


def test_a_refused_save_is_said_after_the_compile_notice_ends(capsys, monkeypatch):
    """The note waits for the compile notice's line to end: not in the middle of it."""
    import errno
    import time

    from vcavity._numba import cache_lock
    from vcavity.simulate.warmup import CompileNotice

    monkeypatch.setattr(cache_lock, "SAVE_FAILURES", [])
    with CompileNotice("beckmann x mirror", delay=0.0) as notice:
        notice._compiling.set()  # as Numba's compile event does
        deadline = time.monotonic() + 30
        while not notice._shown and time.monotonic() < deadline:
            time.sleep(0.01)
        cache_lock._save_refused("/the/cache", OSError(errno.ENOSPC, "No space left on device"))
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and lines[0].startswith("vcavity: compiling the kernel for beckmann x mirror"), lines
    assert lines[1].startswith("vcavity: note: the Numba cache folder '/the/cache' cannot take compiled code "
                               "(No space left on device)"), lines
