"""End-to-end CLI: run writes a readable table and a summary; info reads it; --help explains."""

import subprocess
import sys

import numpy as np
import pytest

from vcavity import open_table
from vcavity.cli import main


@pytest.fixture
def small_config(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(
        '[material]\ndistribution = "ggx"\nalpha = 0.4\nkd = 0.5\neta = 1.5\n'
        "[incidence]\ntheta_i_deg = [0, 60]\npaths = 5000\n"
        "[simulation]\nseed = 9\nsensor_resolution = 9\n"
    )
    return path


def test_run_writes_table_next_to_config_and_prints_summary(small_config, capsys):
    assert main(["run", str(small_config), "-q"]) == 0
    out = capsys.readouterr().out
    table_path = small_config.with_suffix(".h5")
    assert f"wrote {table_path}" in out
    assert "albedo f_inf" in out and "absorbed" in out
    table = open_table(table_path)
    assert list(table.order) == [0, 1, 2, 3]
    assert table.seed == 9
    np.testing.assert_allclose(np.degrees(table.theta_i), [0, 60])
    assert table.config["material"]["distribution"] == "ggx"


def test_overrides_and_info(small_config, tmp_path, capsys):
    out_path = tmp_path / "o.h5"
    assert main(["run", str(small_config), "-o", str(out_path), "--paths", "3000", "--seed", "4",
                 "--threads", "1", "--chunk-blocks", "1", "-q"]) == 0
    table = open_table(out_path)
    assert list(table.paths) == [3000, 3000] and table.seed == 4
    capsys.readouterr()
    assert main(["info", str(out_path)]) == 0
    info = capsys.readouterr().out
    # one line: the distribution and facet names, each with its parameters as stored
    assert "material: v-cavity microsurface, ggx, interfaced_lambertian facets: alpha=0.4 kd=0.5 eta=1.5\n" in info and "3,000" in info


def test_info_on_a_non_table_is_a_one_line_error(tmp_path, capsys):
    bogus = tmp_path / "x.h5"
    bogus.write_text("not hdf5")
    assert main(["info", str(bogus)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("vcavity: error:") and "\n" not in err
    assert main(["info", str(tmp_path / "missing.h5")]) == 2


def test_run_help_documents_keys_units_and_conventions():
    proc = subprocess.run([sys.executable, "-m", "vcavity.cli", "run", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0
    for needle in ("theta_i_deg", "alpha_x", "kd", "eta", "max_bounces", "sensor_resolution", "1/sr", "degrees",
                   "--threads", "--seed", "--paths", "--overwrite"):
        assert needle in proc.stdout, needle
