"""Ctrl-C and SIGTERM of a `vcavity run --dask local:1` (or sweep) say one line and nothing else.

A Ctrl-C in a terminal reaches the whole process group: the run, and the local cluster's
worker processes. The run must still save its checkpoint and print only its own line
(no distributed.* warning, no traceback from a worker or its nanny, no "Exception
ignored", no resource-tracker complaint), exit 130 (143 for SIGTERM), leave no temporary
file, and the checkpoint must resume (here locally) to the table of an uninterrupted
local run, bit for bit. The processes start in their own session, the signal goes to the
process group (os.killpg) as a terminal's would, or to the run alone (``kill PID``), once
the run has saved a checkpoint (polled, not slept). Deterministic: equality only.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from vcavity import open_table
from vcavity.io import checkpoint

pytest.importorskip("distributed")

CONFIG = """
[material]
distribution = "beckmann"
alpha = 0.6
kd = 0.9
[incidence]
theta_i_deg = [40]
paths = 40_000_000
[simulation]
seed = 11
max_order = 2
sensor_resolution = 9
"""
SWEEP = CONFIG.replace("paths = 40_000_000", "paths = 20_000_000") + "[sweep]\nalpha = [0.3, 0.6]\n"
FIELDS = ("counts", "paths", "brdf", "brdf_stderr", "albedo", "absorbed", "truncated", "max_bounces_seen")


class Running:
    """A vcavity subprocess whose stderr is read as it comes (to know what came after the signal)."""

    def __init__(self, argv):
        self.process = subprocess.Popen([sys.executable, "-m", "vcavity.cli", *argv], stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True, start_new_session=True)
        self.err = []
        self.reader = threading.Thread(target=lambda: self.err.extend(iter(self.process.stderr.readline, "")))
        self.reader.start()

    def wait_for(self, ready, what, timeout=240):
        deadline = time.time() + timeout
        while not ready() and self.process.poll() is None and time.time() < deadline:
            time.sleep(0.02)
        assert self.process.poll() is None, f"ended before {what}: {''.join(self.err)}"
        assert ready(), f"no {what} within {timeout} s: {''.join(self.err)}"

    def signal(self, signum, group):
        seen = len(self.err)
        (os.killpg if group else os.kill)(self.process.pid, signum)
        return seen

    def finish(self, timeout=240):
        try:
            code = self.process.wait(timeout)  # its stdout is a few lines: no pipe to drain meanwhile
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)  # a hung shutdown must not hang the suite
            self.process.wait()
            self.reader.join()
            pytest.fail(f"still running {timeout} s after the signal: {''.join(self.err)}")
        self.reader.join()
        return code, self.process.stdout.read()


@pytest.mark.parametrize("signum, group", [(signal.SIGINT, True), (signal.SIGTERM, False), (signal.SIGTERM, True)],
                         ids=["ctrl-c-to-the-group", "kill-pid", "sigterm-to-the-group"])
def test_interrupted_dask_run_says_one_line_and_its_checkpoint_resumes(tmp_path, signum, group):
    (tmp_path / "run.toml").write_text(CONFIG)
    out = tmp_path / "out.h5"
    ckpt = checkpoint.checkpoint_path(out)
    # units of 2^21 paths (the default 512 blocks): a task is running when the signal comes,
    # and is cancelled: the worker's warning about it must not reach the terminal
    run = Running(["run", str(tmp_path / "run.toml"), "-o", str(out), "-q", "--dask", "local:1",
                   "--checkpoint-every", "0.05"])
    run.wait_for(ckpt.exists, "checkpoint")  # tracing on the worker has begun
    seen = run.signal(signum, group)
    code, stdout = run.finish()
    if code == 0:
        pytest.skip("the run finished before the signal arrived (machine too fast for this budget)")
    after = run.err[seen:]
    assert code == (130 if signum == signal.SIGINT else 143), "".join(run.err)
    assert len(after) == 1 and after[0].startswith(f"vcavity: interrupted; checkpoint {ckpt} saved ("), \
        "".join(run.err)
    assert after[0].rstrip().endswith("continue with --resume")
    assert not any(word in "".join(run.err) for word in ("Traceback", "distributed", "Exception ignored", "WARNING"))
    assert stdout == ""
    assert not out.exists() and ckpt.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5.checkpoint", "run.toml"]  # no temporary file
    if signum != signal.SIGINT:
        return  # the resume is the same for every signal: once is enough
    resumed = subprocess.run([sys.executable, "-m", "vcavity.cli", "run", str(tmp_path / "run.toml"), "-o", str(out),
                              "-q", "--resume"], capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming from" in resumed.stderr
    reference = tmp_path / "reference.h5"
    done = subprocess.run([sys.executable, "-m", "vcavity.cli", "run", str(tmp_path / "run.toml"), "-o",
                           str(reference), "-q"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    a, b = open_table(reference), open_table(out)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_ctrl_c_of_a_dask_sweep_says_one_line_and_keeps_its_points(tmp_path):
    """Ctrl-C to the group once the first point is in the file: one line, exit 130, the
    point kept, no temporary file; --resume (locally) finishes the sweep."""
    (tmp_path / "sweep.toml").write_text(SWEEP)
    out = tmp_path / "sweep.h5"
    run = Running(["sweep", str(tmp_path / "sweep.toml"), "-o", str(out), "-q", "--dask", "local:1"])
    run.wait_for(out.exists, "sweep file (first point done)")
    seen = run.signal(signal.SIGINT, True)
    code, stdout = run.finish()
    if code == 0:
        pytest.skip("the sweep finished before the signal arrived (machine too fast for this budget)")
    after = run.err[seen:]
    assert code == 130, "".join(run.err)
    assert len(after) == 1 and after[0].startswith("vcavity: interrupted; 1 of 2 point(s) are in "), "".join(run.err)
    assert not any(word in "".join(run.err) for word in ("Traceback", "distributed", "Exception ignored", "WARNING"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.h5", "sweep.toml"]
    resumed = subprocess.run([sys.executable, "-m", "vcavity.cli", "sweep", str(tmp_path / "sweep.toml"), "-o",
                              str(out), "-q", "--resume"], capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert "1 done" in resumed.stderr
