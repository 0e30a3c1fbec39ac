"""The writer lock (vcavity/io/lock.py): one writer per output, the second refused with the
holder's pid and host, stale locks of gone processes taken over, the lock file removed
when the writer leaves, whatever way it leaves.

Holders are real processes (a child holding the lock until told to stop, or killed with
SIGKILL), probed from this one; lock files of other hosts or of dead pids are written by
hand in the documented format. Nothing here is statistical.
"""

import json
import os
import socket
import subprocess
import sys
import time

import pytest

from vcavity.io import lock
from vcavity.io.lock import LockError, WriterLock, lock_path

# a child that holds the lock of argv[1], says so, and releases it when stdin closes
HOLDER = ("import sys\nfrom vcavity.io.lock import WriterLock\n"
          "with WriterLock(sys.argv[1]):\n    print('held', flush=True)\n    sys.stdin.read()\n")


def _holder(output):
    child = subprocess.Popen([sys.executable, "-c", HOLDER, str(output)], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "held"
    return child


def _dead_pid():
    """The pid of a process that has exited (and been reaped)."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def _write_lock(output, **holder):
    fields = {"pid": 1, "host": socket.gethostname(), "started": "2026-01-01 00:00:00 UTC",
              "command": "vcavity sweep s.toml -o out.h5", "flock": False, **holder}
    lock_path(output).write_text(json.dumps(fields) + "\n")


def test_a_second_writer_is_refused_with_the_holders_pid_and_host(tmp_path):
    out = tmp_path / "out.h5"
    child = _holder(out)
    try:
        with pytest.raises(LockError) as refused:
            with WriterLock(out):
                pass
        message = str(refused.value)
        assert f"pid {child.pid} on host {socket.gethostname()}" in message and "\n" not in message
        assert str(lock_path(out)) in message
        assert json.loads(lock_path(out).read_text())["pid"] == child.pid  # the holder's lock untouched
    finally:
        child.stdin.close()
        child.wait()
    assert child.returncode == 0 and not lock_path(out).exists()  # released on exit
    with WriterLock(out) as held:  # and then free
        assert held.took_over is None
        assert json.loads(lock_path(out).read_text())["pid"] == os.getpid()
    assert not lock_path(out).exists()


def test_the_lock_of_a_killed_writer_is_taken_over(tmp_path):
    out = tmp_path / "out.h5"
    child = _holder(out)
    child.kill()  # SIGKILL: no cleanup runs
    child.wait()
    assert json.loads(lock_path(out).read_text())["pid"] == child.pid  # left behind
    with WriterLock(out) as held:
        assert held.took_over["pid"] == child.pid
        assert f"pid {child.pid}" in held.note() and "gone" in held.note()
        assert json.loads(lock_path(out).read_text())["pid"] == os.getpid()
    assert not lock_path(out).exists()


@pytest.mark.parametrize("flocked", [False, True])
def test_a_stale_lock_of_a_dead_pid_is_taken_over(tmp_path, flocked):
    out = tmp_path / "out.h5"
    pid = _dead_pid()
    _write_lock(out, pid=pid, flock=flocked)
    with WriterLock(out) as held:
        assert held.took_over["pid"] == pid
    assert not lock_path(out).exists()


def test_a_live_pid_counts_as_the_holder_unless_its_flock_is_free(tmp_path):
    out = tmp_path / "out.h5"
    live = os.getppid()  # alive, and not holding this lock
    _write_lock(out, pid=live, flock=False)  # a holder without flock: its pid is all there is
    with pytest.raises(LockError, match=f"pid {live} on host"):
        WriterLock(out).__enter__()
    _write_lock(out, pid=live, flock=True)  # it held flock, nobody does now: that pid was reused
    with WriterLock(out) as held:
        assert held.took_over["pid"] == live


def test_a_lock_of_another_host_is_refused_saying_it_cannot_be_checked(tmp_path):
    out = tmp_path / "out.h5"
    _write_lock(out, pid=_dead_pid(), host="node-elsewhere-17")
    with pytest.raises(LockError) as refused:
        WriterLock(out).__enter__()
    message = str(refused.value)
    assert "host node-elsewhere-17" in message and "cannot be checked" in message
    assert f"remove the lock file {str(lock_path(out))!r}" in message
    assert lock_path(out).exists()  # never removed on a guess


def test_an_empty_lock_file_is_young_being_created_or_old_stale(tmp_path):
    out = tmp_path / "out.h5"
    lock_path(out).write_bytes(b"")
    with pytest.raises(LockError, match="creating its lock file"):
        WriterLock(out).__enter__()
    old = time.time() - 2 * lock.UNNAMED_GRACE_S
    os.utime(lock_path(out), (old, old))
    with WriterLock(out) as held:
        assert held.took_over == {} and "without a holder" in held.note()


def test_released_on_an_error_and_on_ctrl_c(tmp_path):
    out = tmp_path / "out.h5"
    for exc in (RuntimeError("failed"), KeyboardInterrupt()):
        with pytest.raises(type(exc)):
            with WriterLock(out):
                assert lock_path(out).exists()
                raise exc
        assert not lock_path(out).exists()


def test_release_leaves_a_lock_file_that_is_no_longer_ours(tmp_path):
    out = tmp_path / "out.h5"
    with WriterLock(out):
        lock_path(out).unlink()
        lock_path(out).write_text("someone else's\n")
    assert lock_path(out).read_text() == "someone else's\n"


def test_a_folder_that_cannot_hold_a_lock_is_said_in_one_line(tmp_path):
    with pytest.raises(LockError) as refused:
        WriterLock("/proc/out.h5").__enter__()
    assert "cannot create a file in folder '/proc'" in str(refused.value) and "out.h5.lock" in str(refused.value)
    os.mkdir(lock_path(tmp_path / "out.h5"))  # a folder where the lock file goes
    with pytest.raises(LockError, match="not a lock file"):
        WriterLock(tmp_path / "out.h5").__enter__()


def test_without_flock_the_pid_decides(tmp_path, monkeypatch):
    monkeypatch.setattr(lock, "fcntl", None)  # a file system (or OS) without flock
    out = tmp_path / "out.h5"
    with WriterLock(out):
        assert json.loads(lock_path(out).read_text())["flock"] is False
    _write_lock(out, pid=_dead_pid())
    with WriterLock(out) as held:
        assert held.took_over is not None
    _write_lock(out, pid=os.getppid())
    with pytest.raises(LockError):
        WriterLock(out).__enter__()


# several writers starting at once on a stale lock: each takes it, waits, releases, reports
CONTENDER = ("import sys, time\nfrom vcavity.io.lock import LockError, WriterLock\n"
             "time.sleep(max(0.0, float(sys.argv[2]) - time.time()))\n"
             "try:\n    with WriterLock(sys.argv[1]):\n        print('won', flush=True)\n        time.sleep(1.5)\n"
             "except LockError as exc:\n    print('refused', exc, flush=True)\n")


def test_of_writers_starting_together_on_a_stale_lock_one_wins(tmp_path):
    out = tmp_path / "out.h5"
    for attempt in range(3):
        _write_lock(out, pid=_dead_pid(), flock=attempt % 2 == 1)
        start = time.time() + 1.0
        children = [subprocess.Popen([sys.executable, "-c", CONTENDER, str(out), str(start)],
                                     stdout=subprocess.PIPE, text=True) for _ in range(6)]
        answers = [child.communicate(timeout=60)[0].strip() for child in children]
        assert sum(a == "won" for a in answers) == 1, answers
        assert all(a == "won" or a.startswith("refused") for a in answers), answers
        assert not lock_path(out).exists()


def test_a_writer_late_to_remove_a_stale_lock_leaves_the_new_holders_lock(tmp_path):
    # A judged the lock stale; B, faster, took it over (its new lock file may even reuse
    # the old inode number); A's removal must now leave B's lock alone
    out = tmp_path / "out.h5"
    _write_lock(out, pid=_dead_pid())
    seen = lock._look(lock_path(out))
    late = WriterLock(out)
    with WriterLock(out) as fast:
        assert fast.took_over is not None
        late._remove_stale(seen)
        assert json.loads(lock_path(out).read_text())["pid"] == os.getpid()  # B's lock stands
        with pytest.raises(LockError):
            late.__enter__()
