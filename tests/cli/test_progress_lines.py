"""What the progress lines say (issue 38 item 2): a sweep whose estimator traces no path
(exact) counts points, not paths it never traces; a progress bar ends its line before an
error is printed, so the error's line starts with ``vcavity: error:`` (no bar fragment).

The bars run (no ``-q``) into captured stderr; runs use the variants the CLI tests
compile (beckmann + interfaced Lambertian 9 x 9; the exact model of a Beckmann mirror).
Nothing here is statistical.
"""

import errno
import os

from vcavity.cli import main
from vcavity.io import atomic, sweep_points

EXACT_SWEEP = """[material]
distribution = "beckmann"
facet = "mirror"
[incidence]
phi_i_deg = 20
paths = 1000
[simulation]
seed = 5
max_order = 3
sensor_resolution = 17
estimator = "exact"
[sweep]
alpha = [0.3, 0.9]
theta_i_deg = [0, 60]
"""
TRACED = """[material]
distribution = "beckmann"
alpha = 0.5
kd = 0.5
eta = 1.5
[incidence]
theta_i_deg = [0.0, 45.0]
paths = 4096
[simulation]
sensor_resolution = 9
"""


def _bar_states(err: str) -> list[str]:
    """Every state a tqdm bar drew (its redraws are separated by carriage returns)."""
    return [part.strip() for line in err.split("\n") for part in line.split("\r") if "sweeping" in part]


def test_an_exact_sweep_counts_points_not_paths(tmp_path, capsys):
    (tmp_path / "s.toml").write_text(EXACT_SWEEP)
    assert main(["sweep", str(tmp_path / "s.toml"), "-o", str(tmp_path / "s.h5")]) == 0
    err = capsys.readouterr().err
    header = [line for line in err.splitlines() if "point(s) x" in line]
    assert len(header) == 1 and header[0].endswith("2 point(s) x 2 direction(s), 0 done, no path (exact estimator)")
    states = _bar_states(err)
    assert states and "2/2" in states[-1] and "point" in states[-1] and "path" not in states[-1], states


def _error_lines(err: str) -> list[str]:
    return [line for line in err.split("\n") if "error:" in line]


def test_a_sweep_bar_ends_before_the_error_line(tmp_path, capsys, monkeypatch):
    (tmp_path / "s.toml").write_text(TRACED.replace("theta_i_deg = [0.0, 45.0]\n", "")
                                     + "[sweep]\nalpha = [0.3, 0.6]\ntheta_i_deg = [0]\n")
    real, calls = sweep_points.write_at, []

    def write_at(fd, data, offset):  # the disk fills in the second point's in-place commit
        calls.append(offset)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd, data, offset)

    monkeypatch.setattr(sweep_points, "write_at", write_at)
    assert main(["sweep", str(tmp_path / "s.toml"), "-o", str(tmp_path / "s.h5")]) == 2
    err = capsys.readouterr().err
    assert _bar_states(err), err  # a bar was drawn
    lines = _error_lines(err)
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: --output = "), repr(err)


def test_a_run_bar_ends_before_the_error_line(tmp_path, capsys, monkeypatch):
    (tmp_path / "c.toml").write_text(TRACED)
    real, calls = atomic.write_bytes, []

    def write_bytes(temporary, data):  # the second checkpoint meets a full disk, mid-run
        if ".checkpoint." in temporary.name:
            calls.append(temporary)
            if len(calls) == 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(temporary, data)

    monkeypatch.setattr(atomic, "write_bytes", write_bytes)
    status = main(["run", str(tmp_path / "c.toml"), "-o", str(tmp_path / "new.h5"), "--checkpoint-every", "1e-9"])
    err = capsys.readouterr().err
    assert status == 2
    assert any("tracing" in part for part in err.split("\r")), err  # a bar was drawn
    lines = _error_lines(err)
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: --output = "), repr(err)
