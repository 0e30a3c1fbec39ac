"""``vcavity plot ... --kind versus`` from the command line: what cannot be compared is one
line on stderr naming the option or what differs, exit status 2, and no image; what can
is written (atomically, by the output rules of every plot kind).

Inputs: tables of random counts and sweeps of random values (tests/plots/versus_inputs.py).
"""

import pytest

from tests.plots.png_checks import assert_png
from tests.plots.versus_inputs import MATERIAL, random_sweep, random_table
from vcavity.cli import main

SMITH = {"microsurface": "smith", **MATERIAL}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("versus_cli")
    return {
        "a": random_table(folder / "a.h5", [0.0, 60.0], seed=1),
        "smith": random_table(folder / "smith.h5", [60.0, 0.0], seed=2, material=SMITH),
        "kd": random_table(folder / "kd.h5", [0.0, 60.0], seed=3, material=dict(SMITH, kd=0.8)),
        "n8": random_table(folder / "n8.h5", [0.0, 60.0], seed=4, material=SMITH, resolution=8),
        "other_theta": random_table(folder / "t.h5", [10.0, 20.0], seed=5, material=SMITH),
        "no_f3": random_table(folder / "no_f3.h5", [0.0], seed=6, material=SMITH, orders=(0, 1, 2)),
        "sweep": random_sweep(folder / "s.h5", [("microsurface", ["v-cavity", "smith"]), ("alpha", [0.1, 0.5, 1.0]),
                                                ("theta_i_deg", [0.0, 60.0])],
                              pending=[{"alpha": 1.0, "microsurface": "smith"}]),
    }


def _refused(capsys, argv, *fragments, output=None):
    """Exit 2, one line on stderr holding every fragment, nothing on stdout, no image."""
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: "), captured.err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert captured.out == ""
    if output is not None:
        assert not output.exists()
    return lines[0]


def test_two_tables_of_one_material_are_drawn(files, tmp_path, capsys):
    out = tmp_path / "v.png"
    assert main(["plot", str(files["a"]), str(files["smith"]), "-o", str(out)]) == 0  # versus: the default
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert_png(out)


def test_the_default_output_is_beside_the_first_table(files, capsys):
    out = files["a"].with_name("a_versus.png")
    assert main(["plot", str(files["a"]), str(files["smith"]), "--kind", "versus"]) == 0
    assert out.is_file() and capsys.readouterr().out.strip() == f"wrote {out}"
    _refused(capsys, ["plot", str(files["a"]), str(files["smith"])], "a_versus.png", "--overwrite")
    assert main(["plot", str(files["a"]), str(files["smith"]), "--overwrite"]) == 0
    out.unlink()


def test_other_materials_are_refused_unless_forced(files, tmp_path, capsys):
    out = tmp_path / "v.png"
    _refused(capsys, ["plot", str(files["a"]), str(files["kd"]), "-o", str(out)], "kd 0.9 vs 0.8", "--force",
             output=out)
    assert main(["plot", str(files["a"]), str(files["kd"]), "-o", str(out), "--force"]) == 0
    assert_png(out)


@pytest.mark.parametrize("name, fragments", [
    ("n8", ("9x9", "8x8", "sensor_resolution")),
    ("other_theta", ("share no incident direction", "0/0, 60/0", "10/0, 20/0")),
])
def test_what_cannot_be_subtracted_is_refused(files, tmp_path, capsys, name, fragments):
    out = tmp_path / "v.png"
    _refused(capsys, ["plot", str(files["a"]), str(files[name]), "-o", str(out)], *fragments, output=out)


@pytest.mark.parametrize("extra, fragments", [
    (["--order", "3"], ("--order = 3", "no_f3.h5", "orders 0 (f_inf), 1, 2")),
    (["--theta-i", "60"], ("--theta-i = 60", "theta_i_deg: 0")),
    (["--kind", "slice"], ("--kind = 'slice'", "--kind versus")),
    (["--point", "alpha=0.5"], ("--point", "are tables")),
    (["--scale", "cubic"], ("--scale = 'cubic'",)),
])
def test_bad_options_with_two_tables(files, tmp_path, capsys, extra, fragments):
    out = tmp_path / "v.png"
    _refused(capsys, ["plot", str(files["a"]), str(files["no_f3"]), "-o", str(out), *extra], *fragments, output=out)


def test_the_output_is_never_an_input_nor_are_three_inputs_taken(files, tmp_path, capsys):
    import shutil

    second = tmp_path / "b.png"  # a table under an image's name: only its being an input refuses it
    shutil.copyfile(files["smith"], second)
    before = second.read_bytes()
    for argv in (["plot", str(files["a"]), str(second)], ["plot", str(second), str(files["a"])]):
        _refused(capsys, [*argv, "-o", str(second), "--overwrite"], "b.png")
        assert second.read_bytes() == before
    _refused(capsys, ["plot", str(files["a"]), str(files["smith"]), str(files["kd"])], "at most two")
    _refused(capsys, ["plot", str(files["a"]), "--kind", "versus"], "two tables", "a.h5 is one table")
    _refused(capsys, ["plot", str(files["a"]), str(files["sweep"])], "s.h5 is a sweep file")


def test_two_points_of_a_sweep_are_drawn(files, tmp_path, capsys):
    out = tmp_path / "s.png"
    assert main(["plot", str(files["sweep"]), "--kind", "versus", "--point", "alpha=0.5", "-o", str(out)]) == 0
    assert_png(out)


@pytest.mark.parametrize("extra, fragments", [
    ([], ("--point is needed for axis alpha", "0.1, 0.5, 1", "--point alpha=0.1")),
    (["--point", "alpha=0.35"], ("--point = '0.35'", "axis alpha", "0.1, 0.5, 1")),
    (["--point", "beta=0.35"], ("--point = 'beta=0.35'", "point axes: microsurface, alpha")),
    (["--point", "theta_i_deg=0"], ("--point = 'theta_i_deg=0'", "--theta-i")),
    (["--point", "alpha=1.0"], ("alpha=1", "smith", "not done")),
    (["--versus", "alpha", "--point", "microsurface=smith"], ("--versus = 'alpha'", "3 values", "alpha=A,B")),
    (["--versus", "alpha=0.1", "--point", "microsurface=smith"], ("--versus = 'alpha=0.1'", "two values")),
    (["--point", "alpha=0.5", "--versus", "microsurface=smith,smith"], ("same point",)),
    (["--point", "alpha=0.5", "--kind", "sweep"], ("--point", "--kind versus")),
])
def test_bad_points_of_a_sweep(files, tmp_path, capsys, extra, fragments):
    out = tmp_path / "s.png"
    kind = [] if "--kind" in extra else ["--kind", "versus"]
    _refused(capsys, ["plot", str(files["sweep"]), *kind, "-o", str(out), *extra], *fragments, output=out)
