"""Defects a careless-user trial of the CLI found (issue 20, the third trial), each pinned.

Every case: exit status 2, one line on stderr naming the flag or field as written, the
value and what is accepted, nothing on stdout, no file written. Deterministic.
"""

import pytest

from tests.export.synthetic_table import synthetic
from vcavity.cli import main

SWEEP = """
[material]
distribution = "beckmann"
alpha = 0.5
kd = 0.5
[incidence]
theta_i_deg = [30]
paths = 4096
[simulation]
sensor_resolution = 7
[sweep]
alpha = [0.3, 0.6]
"""


def _one_line_error(capsys, status):
    captured = capsys.readouterr()
    assert status == 2 and captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: "), captured.err
    return lines[0]


@pytest.mark.parametrize("command", ["run", "sweep", "export"])
def test_dash_is_not_a_file_named_dash(tmp_path, capsys, monkeypatch, command):
    """``-o -`` (or export's FILE ``-``) wrote a file named '-' in the current folder."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(SWEEP)
    (tmp_path / "r.toml").write_text(SWEEP.split("[sweep]")[0])
    table = synthetic(tmp_path / "t.h5", theta_deg=(0, 30), resolution=7).path
    argv = {"run": ["run", "r.toml", "-o", "-", "-q"], "sweep": ["sweep", "s.toml", "-o", "-", "-q"],
            "export": ["export", str(table), "-", "--format", "csv", "--theta-i", "30"]}[command]
    line = _one_line_error(capsys, main(argv))
    field = {"run": "--output", "sweep": "--output", "export": "FILE"}[command]
    assert line.startswith(f"vcavity: error: {field} = '-': is not standard output here"), line
    assert not (tmp_path / "-").exists()


@pytest.mark.parametrize("command", ["info", "compare", "plot"])
def test_the_missing_input_is_called_a_table(capsys, command):
    """``vcavity info`` without its argument asked for 'OUT.h5', an output, for what it reads."""
    with pytest.raises(SystemExit) as exited:  # argparse's own error exits
        main([command])
    line = _one_line_error(capsys, exited.value.code)
    assert "TABLE.h5" in line and "OUT.h5" not in line, line


def test_a_sweep_interrupted_before_its_first_point_says_nothing_was_written(tmp_path, capsys, monkeypatch):
    """It said '0 of 2 point(s) are in s.h5' of a file that does not exist."""
    import vcavity.sweep.run as sweep_run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_run, "run", interrupted)
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "s.h5"
    assert main(["sweep", str(tmp_path / "s.toml"), "-o", str(out), "-q"]) == 130
    lines = capsys.readouterr().err.splitlines()
    assert lines[-1] == (f"vcavity: interrupted; no point finished, nothing written to {out} "
                         f"(continue with: vcavity sweep {tmp_path / 's.toml'} -o {out} --resume)")
    assert not out.exists()


def test_an_overwrite_interrupted_before_its_first_point_leaves_the_old_file_and_says_so(tmp_path, capsys,
                                                                                        monkeypatch):
    """The issue 38 trial: it said '0 of 2 point(s) are in s.h5 (continue with ... --resume)' of
    the old file --overwrite had not replaced yet, whose --resume is then refused."""
    import vcavity.sweep.run as sweep_run

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_run, "run", interrupted)
    (tmp_path / "s.toml").write_text(SWEEP)
    out = tmp_path / "s.h5"
    out.write_bytes(b"an older file\n")
    assert main(["sweep", str(tmp_path / "s.toml"), "-o", str(out), "-q", "--overwrite"]) == 130
    lines = capsys.readouterr().err.splitlines()
    assert lines[-1] == (f"vcavity: interrupted; no point finished, {out} is unchanged (start again with: "
                         f"vcavity sweep {tmp_path / 's.toml'} -o {out} --overwrite)")
    assert out.read_bytes() == b"an older file\n"


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_device_as_config_is_refused_not_read_forever(command):
    """``vcavity run /dev/zero`` read zeros until memory ran out (killed after 20 s in the trial)."""
    import os
    import subprocess
    import sys

    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero here")
    done = subprocess.run([sys.executable, "-m", "vcavity.cli", command, "/dev/zero", "-q"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == ""
    what = "config file" if command == "run" else "sweep file"
    assert done.stderr.splitlines() == [f"vcavity: error: {what} '/dev/zero': is a character device; a TOML file "
                                        "(or a pipe) is expected"]


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_config_over_1_mib_is_refused(tmp_path, capsys, command):
    """Read whole before: 2 MiB of comments parsed as an empty config ('material is missing')."""
    big = tmp_path / "big.toml"
    big.write_text(SWEEP + ("# padding\n" * (1 << 18))[: 2 << 20])
    line = _one_line_error(capsys, main([command, str(big), "-o", str(tmp_path / "o.h5"), "-q"]))
    what = "config file" if command == "run" else "sweep file"
    assert line == f"vcavity: error: {what} {str(big)!r}: larger than 1 MiB; not a TOML config"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.toml"]
