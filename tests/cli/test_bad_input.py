"""Parameters exactly at the edge of validity get the same one-line errors as any bad input:
exit status 2, one line on stderr naming the field and value, nothing on stdout, no
output file (not even a temporary one). Values just inside the edge run.
"""

import os

import pytest

from vcavity.cli import main
from vcavity.cli.common import EXIT_BAD_INPUT
from vcavity.io.table import open_table

BASE_MATERIAL = {"distribution": '"beckmann"', "alpha": "0.5", "kd": "0.5", "eta": "1.5"}
BASE_INCIDENCE = {"theta_i_deg": "[0.0, 45.0]", "paths": "4096"}


def _write_config(folder, material=None, incidence=None):
    material = {**BASE_MATERIAL, **(material or {})}
    incidence = {**BASE_INCIDENCE, **(incidence or {})}
    lines = ["[material]"] + [f"{k} = {v}" for k, v in material.items() if v is not None]
    lines += ["[incidence]"] + [f"{k} = {v}" for k, v in incidence.items()]
    lines += ["[simulation]", "sensor_resolution = 9"]
    path = folder / "edge.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _run_bad(tmp_path, capsys, **sections):
    config = _write_config(tmp_path, **sections)
    out_path = tmp_path / "out.h5"
    status = main(["run", str(config), "-o", str(out_path), "-q"])
    captured = capsys.readouterr()
    assert status == EXIT_BAD_INPUT == 2
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["edge.toml"]  # no table, no temporary
    return lines[0]


EDGES = [
    # (section, key, TOML value, text the message must contain)
    ("material", "alpha", "0.0", "material.alpha = 0.0: must be > 0"),
    ("material", "alpha", "-0.0", "material.alpha = -0.0: must be > 0"),
    ("material", "kd", "1.000000000001", "material.kd = 1.000000000001: must be in [0, 1]"),
    ("material", "kd", "-5e-324", "material.kd = -5e-324: must be in [0, 1]"),
    ("material", "eta", "0.999999999999", "material.eta = 0.999999999999: must be >= 1"),
    ("incidence", "theta_i_deg", "90.0", "incidence.theta_i_deg = 90.0: must be in [0, 90) degrees"),
    ("incidence", "theta_i_deg", "[0.0, 90.0]", "incidence.theta_i_deg = 90.0: must be in [0, 90) degrees"),
    ("incidence", "theta_i_deg", "-1e-300", "incidence.theta_i_deg = -1e-300: must be in [0, 90) degrees"),
    ("material", "alpha", "nan", "material.alpha = nan: must be a finite number"),
    ("material", "eta", "inf", "material.eta = inf: must be a finite number"),
]


@pytest.mark.parametrize("section, key, value, message", EDGES, ids=[f"{e[1]}={e[2]}" for e in EDGES])
def test_edge_of_validity_is_a_one_line_error_without_output(tmp_path, capsys, section, key, value, message):
    line = _run_bad(tmp_path, capsys, **{section: {key: value}})
    assert message in line


@pytest.mark.parametrize("material, message", [
    ({"distribution": '"ggx"', "alpha": None, "alpha_x": "0.0", "alpha_y": "0.3"}, "material.alpha_x = 0.0: must be > 0"),
    ({"distribution": '"gaussian"', "alpha": None, "sigma": "0.0"}, "material.sigma = 0.0: must be > 0"),
    ({"distribution": '"phong"', "alpha": None, "exponent": "-1e-300"}, "material.exponent = -1e-300: must be >= 0"),
])
def test_edge_of_each_roughness_parameter(tmp_path, capsys, material, message):
    assert message in _run_bad(tmp_path, capsys, material=material)


@pytest.mark.slow  # ~20 s: runs in CI's slow suite (keeps the default suite under 10 min)
def test_values_just_inside_the_edge_run(tmp_path, capsys):
    # kd = 1 and 0, eta = 1, theta_i one ulp below 90 deg, tiny alpha: valid, and they run
    for material in ({"kd": "1.0", "eta": "1.0", "alpha": "1e-12"}, {"kd": "0.0", "eta": "1.0000000000002"}):
        config = _write_config(tmp_path, material=material, incidence={"theta_i_deg": "[0.0, 89.99999999999999]"})
        out_path = tmp_path / "inside.h5"
        assert main(["run", str(config), "-o", str(out_path), "-q"]) == 0
        table = open_table(out_path)
        assert table.degenerate.sum() == 0 and (table.brdf >= 0).all()
        out_path.unlink()
    capsys.readouterr()


@pytest.mark.parametrize("material, message", [
    ({"kd": None}, "material.kd is missing: facet 'interfaced_lambertian' needs kd ("),
    ({"facet": '"mirror"', "eta": None}, "material.kd = 0.5: not used by facet 'mirror' (it takes: nothing)"),
    ({"exponent": "20.0"}, "material.exponent = 20.0: not a parameter of distribution 'beckmann' "
                           "(it takes: alpha, alpha_x, alpha_y)"),
])
def test_missing_and_misplaced_parameters(tmp_path, capsys, material, message):
    assert message in _run_bad(tmp_path, capsys, material=material)


CONDUCTOR = {"facet": '"conductor"', "kd": None, "eta": "0.43", "k": "2.455"}
CONDUCTOR_EDGES = [
    ({"eta": "0.0"}, "material.eta = 0.0: must be > 0"),
    ({"eta": "-0.43"}, "material.eta = -0.43: must be > 0"),
    ({"k": "-1e-300"}, "material.k = -1e-300: must be >= 0"),
    ({"kd": "0.5"}, "material.kd = 0.5: not used by facet 'conductor' (it takes: eta, k)"),
    # gold's k with another metal's eta (or the reverse) is no metal: one of the pair alone is refused
    ({"k": None, "eta": "0.2"}, "material.k is missing: facet 'conductor' needs k (>= 0) with material.eta = 0.2; "
                                "the default k = 2.455 holds only when eta is not given either"),
    ({"eta": None, "k": "4.0"}, "material.eta is missing: facet 'conductor' needs eta (> 0) with material.k = 4.0;"),
]


@pytest.mark.parametrize("edit, message", CONDUCTOR_EDGES,
                         ids=[" ".join(f"{k}={v}" for k, v in e[0].items()) for e in CONDUCTOR_EDGES])
def test_bad_conductor_input_is_a_one_line_error_without_output(tmp_path, capsys, edit, message):
    line = _run_bad(tmp_path, capsys, material={**CONDUCTOR, **edit})
    assert message in line


def _piped(text: str, opened: list) -> str:
    """A config read from a pipe, as ``<(cat c.toml)`` gives it: ``/dev/fd/N`` (N added to ``opened``)."""
    read, write = os.pipe()
    os.write(write, text.encode())
    os.close(write)
    opened.append(read)
    return f"/dev/fd/{read}"


@pytest.mark.parametrize("command, extra", [("run", ""), ("run", '[output]\npath = "t.h5"\n'),
                                            ("sweep", "[sweep]\nalpha = [0.3, 0.6]\n")],
                         ids=["run", "run-output.path", "sweep"])
def test_a_piped_config_needs_o(tmp_path, capsys, monkeypatch, command, extra):
    """Without -o the output was named after the pipe (/dev/fd/63.h5) or placed beside it."""
    if not os.path.isdir("/dev/fd"):
        pytest.skip("no /dev/fd here")
    monkeypatch.chdir(tmp_path)
    text, opened = _write_config(tmp_path).read_text() + extra, []
    try:
        config = _piped(text, opened)
        status = main([command, config, "-q"])
        captured = capsys.readouterr()
        assert status == EXIT_BAD_INPUT and captured.out == ""
        assert captured.err.splitlines() == [
            f"vcavity: error: config file {config!r}: is a FIFO (named pipe), not a regular file, so the output "
            "cannot be named after it (nor beside it); give the output with -o OUT.h5"]
        assert sorted(p.name for p in tmp_path.iterdir()) == ["edge.toml"]
        assert main([command, _piped(text, opened), "-o", "piped.h5", "-q"]) == 0  # with -o it runs
    finally:
        for fd in opened:
            os.close(fd)
    if command == "run":
        assert open_table(tmp_path / "piped.h5").paths.sum() == 2 * 4096
