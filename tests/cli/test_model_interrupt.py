"""Ctrl-C and SIGTERM stop an exact model within seconds (issue 38: an exact sweep ignored
SIGINT for 129 s until its point finished). Real processes, in their own process group;
the signal is sent seconds into a model of tens of seconds (a conductor refined until its
mesh hits its cap), after the compile (the "code ready" line), so it lands in the model.
The models poll the stop request between compiled calls of about 0.25 s
(vcavity/analytic/batches.py); before, one call of the finest mesh took 12-14 s here."""

import os
import signal
import subprocess
import sys
import time

import h5py
import pytest

#: Seconds a command may take to answer the signal: a call or two, the process's exit.
ANSWER_S = 4.0

_CONFIG = """[material]
distribution = "ggx"
alpha = 0.5
facet = "conductor"
[incidence]
theta_i_deg = [10, 65]
phi_i_deg = 20
[simulation]
max_order = 3
sensor_resolution = 17
estimator = "exact"
target_error = {target}
"""


def _start(argv, cwd):
    return subprocess.Popen([sys.executable, "-m", "vcavity", *argv], cwd=cwd, start_new_session=True, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _signal_after(proc, wait_for, delay, signum):
    """Send ``signum`` to the group ``delay`` s after a stderr line holding ``wait_for``;
    returns ``(seconds to exit, stderr)``."""
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if wait_for in line:
            break
    time.sleep(delay)
    assert proc.poll() is None, "".join(seen)  # still computing the model
    sent = time.monotonic()
    os.killpg(proc.pid, signum)
    _, err = proc.communicate(timeout=300)
    return time.monotonic() - sent, "".join(seen) + err


@pytest.mark.parametrize("signum, status, delay", [(signal.SIGINT, 130, 8.0), (signal.SIGTERM, 143, 3.0)])
def test_an_exact_run_answers_within_seconds(tmp_path, signum, status, delay):
    """8 s in, the model is in its finest meshes here (one call of 12-14 s before they were cut)."""
    (tmp_path / "c.toml").write_text(_CONFIG.format(target=1e-6))
    proc = _start(["run", "c.toml", "-o", "c.h5"], tmp_path)
    seconds, err = _signal_after(proc, "every-order model code ready", delay, signum)
    assert proc.returncode == status, err
    assert seconds < ANSWER_S, f"answered after {seconds:.1f} s"
    assert err.splitlines()[-1] == "vcavity: interrupted; no table written" and "Traceback" not in err, err
    assert sorted(os.listdir(tmp_path)) == ["c.toml"]


@pytest.mark.slow
def test_an_exact_sweep_answers_within_seconds_and_keeps_its_finished_point(tmp_path):
    """Slow: the first point (a minute here) must finish before the second is interrupted."""
    (tmp_path / "s.toml").write_text(_CONFIG.format(target=1e-5).replace("theta_i_deg = [10, 65]\nphi_i_deg = 20\n", "")
                                     + "[sweep]\nalpha = [0.5, 0.4]\ntheta_i_deg = [30]\n")
    out = tmp_path / "s.h5"
    proc = _start(["sweep", "s.toml", "-o", "s.h5", "-q"], tmp_path)

    def done():
        try:
            with h5py.File(out, "r") as h5:
                return int(h5["done"][()].sum())
        except (OSError, KeyError):
            return 0

    deadline = time.monotonic() + 900
    while done() < 1 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(10.0)  # into the second point's finest meshes (calls of 12-14 s before they were cut)
    assert proc.poll() is None
    sent = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    assert time.monotonic() - sent < ANSWER_S
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert err.splitlines()[-1].startswith("vcavity: interrupted; 1 of 2 point(s) are in "), err
    assert done() == 1
