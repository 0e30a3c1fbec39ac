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
