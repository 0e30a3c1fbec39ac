"""Output piped into a reader that has gone (``vcavity info T.h5 | head -1``): no traceback.

The reader end of a real pipe is closed before the command starts, so every write to
the command's stdout (or stderr) fails with EPIPE, deterministically (no race with a
``head`` that may or may not have read yet). Wanted: nothing on stderr but what the
command says anyway (no traceback, no "Exception ignored ... BrokenPipeError"), the exit
status the command has with a working stdout (its work is done: info 0, compare its
verdict), and a ``run`` whose stdout broke still writes its table. Deterministic.
"""

import os
import subprocess
import sys

import pytest

from tests.export.synthetic_table import synthetic

RUN = """
[material]
distribution = "beckmann"
alpha = 0.6
kd = 0.9
[incidence]
theta_i_deg = [30]
paths = 40_000
[simulation]
seed = 2
max_order = 2
sensor_resolution = 7
"""


def vcavity(*argv, broken=("stdout",), cwd=None):
    """Run ``python -m vcavity.cli ARGV`` with the named streams writing into a pipe whose
    reader is already closed; the other stream is captured. Returns (status, captured text)."""
    read, write = os.pipe()
    os.close(read)
    try:
        streams = {name: (write if name in broken else subprocess.PIPE) for name in ("stdout", "stderr")}
        done = subprocess.run([sys.executable, "-m", "vcavity.cli", *argv], **streams, cwd=cwd, timeout=600)
    finally:
        os.close(write)
    captured = done.stderr if "stderr" not in broken else done.stdout
    return done.returncode, (captured or b"").decode()


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    return synthetic(tmp_path_factory.mktemp("pipes") / "t.h5", theta_deg=(0, 30, 60), resolution=9).path


# (``--help`` is not among them: argparse drops an OSError of its own writes, so
# ``vcavity sweep --help | head -1`` was already quiet, and a test of it could not fail)
@pytest.mark.parametrize("argv", [["info", "{t}"], ["compare", "{t}"],
                                  ["export", "{t}", "{out}", "--format", "csv", "--theta-i", "30"]],
                         ids=["info", "compare", "export"])
def test_a_reader_gone_is_no_error(table, tmp_path, argv):
    argv = [a.format(t=table, out=tmp_path / "s.csv") for a in argv]
    status, err = vcavity(*argv)
    assert "Traceback" not in err and "BrokenPipe" not in err and "Exception ignored" not in err, err
    (tmp_path / "s.csv").unlink(missing_ok=True)
    expected = subprocess.run([sys.executable, "-m", "vcavity.cli", *argv], capture_output=True, timeout=600)
    assert status == expected.returncode, (err, expected.stderr)
    assert err == expected.stderr.decode()  # the same messages (if any) as with a working stdout


def test_a_run_whose_stdout_broke_writes_its_table(tmp_path):
    (tmp_path / "run.toml").write_text(RUN)
    out = tmp_path / "run.h5"
    status, err = vcavity("run", "run.toml", "-o", "run.h5", "-q", cwd=tmp_path)
    assert status == 0, err
    assert "Traceback" not in err and "Exception ignored" not in err
    from vcavity import open_table

    assert open_table(out).paths.sum() == 40_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5", "run.toml"]  # no temporary file


def test_a_run_whose_stdout_and_stderr_broke_writes_its_table(tmp_path):
    """``vcavity run ... 2>&1 | head -1``: the progress bar and the messages break too."""
    (tmp_path / "run.toml").write_text(RUN)
    status, _ = vcavity("run", "run.toml", "-o", "run.h5", broken=("stdout", "stderr"), cwd=tmp_path)
    assert status == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5", "run.toml"]
