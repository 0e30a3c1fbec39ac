"""``vcavity export --format csv``: the in-plane slice, against cells chosen here from the
sensor's definition (tests/reference/sensor.py), not through vcavity.plots.

Tables are synthetic (tests/export/synthetic_table.py): a BRDF with no mirror symmetry,
so every cell of a slice holds its own value and a wrong or mirrored cell shows. Nothing
is simulated or statistical; every check is exact or at the rounding of the written angles.
"""

import csv
import hashlib
import json
import math

import numpy as np
import pytest

from tests.export.synthetic_table import lobe, synthetic
from tests.reference import sensor as ref_sensor
from vcavity import __version__
from vcavity.cli import main

COLUMNS = ["theta_o_deg", "phi_o_deg", "cell", "brdf", "brdf_stderr"]


def tilted(wi, wo):
    """The lobe plus a ramp in wo_x + 2 wo_y: no mirror symmetry about any plane of incidence."""
    return lobe(wi, wo) + 0.02 * (wo[..., 0] + 2.0 * wo[..., 1])


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("csv")
    specs = {
        "three": dict(theta_deg=(0, 30, 60), resolution=9),  # odd N: a middle row of cells
        "ninety": dict(theta_deg=(40,), phi_deg=90.0, resolution=9),  # a middle column
        "even": dict(theta_deg=(30,), resolution=8),  # the plane runs along a cell border
        "azimuths": dict(theta_deg=(30, 30, 60), phi_deg=(0, 90, 0), resolution=9),
    }
    return {name: synthetic(folder / f"{name}.h5", tilted, **spec) for name, spec in specs.items()}


def export_csv(table, out, *options):
    return main(["export", str(table.path), str(out), "--format", "csv", *options])


def read_rows(path):
    """Comment lines, header and rows through the csv module (comment lines dropped first)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    comments = [line[2:] for line in lines if line.startswith("# ")]
    reader = csv.reader(line for line in lines if not line.startswith("#"))
    header = next(reader)
    return comments, header, [[float(x) for x in row] for row in reader]


def signed_theta_deg(s):
    """Signed slice angle of the square point at coordinate ``s`` along the plane's axis,
    ``s > 0`` toward the light: z = 1 - s^2 on an axis of the square (the sensor's lift)."""
    return -np.sign(s) * np.degrees(np.arccos(1.0 - np.asarray(s) ** 2))


def expected_slice(table, index, order_slot, offset):
    """Cells of the slice chosen from the cell centres, with their values, in slice order.

    For phi_i = 0 (90 deg) the plane of incidence is the axis v = 0 (u = 0) of the sensor
    square, and +u (+v) points toward the light. ``offset`` 0: the cells whose centre lies
    in the plane (odd N); ``offset`` 1/N: the two rows of cells either side of a plane
    running along a border (even N). Returns rows (theta_o_deg, phi_o_deg, cell, brdf,
    brdf_stderr) sorted by angle and cell; theta_o_deg is the middle of the cell's extent
    along the plane.
    """
    n = table.sensor.resolution
    phi_i_deg = float(table.phi_i_deg[index])
    assert phi_i_deg in (0.0, 90.0)
    phi_i = math.radians(phi_i_deg)
    u0, u1, v0, v1 = ref_sensor.cell_bounds(n)
    u, v = 0.5 * (u0 + u1), 0.5 * (v0 + v1)
    if offset == 0:  # the centre's direction is in the plane: normal . centre = 0
        normal = np.array([-math.sin(phi_i), math.cos(phi_i), 0.0])
        chosen = np.flatnonzero(np.abs(ref_sensor.square_to_direction(u, v) @ normal) < 1e-12)
    else:
        chosen = np.flatnonzero(np.isclose(np.abs(v if phi_i_deg == 0.0 else u), offset, atol=1e-12))
    rows = []
    for cell in chosen:
        along = (u0[cell], u1[cell]) if phi_i_deg == 0.0 else (v0[cell], v1[cell])
        middle = 0.5 * float(np.sum(signed_theta_deg(np.array(along))))
        phi_o = phi_i_deg if middle < -1e-6 else phi_i_deg + 180.0
        rows.append((middle, 180.0 - (180.0 - phi_o) % 360.0, int(cell),
                     float(table.brdf[index, order_slot, cell]),
                     float(table.brdf_stderr[index, order_slot, cell])))
    return sorted(rows, key=lambda row: (row[0], row[2]))


@pytest.mark.parametrize("name, theta_i, index", [("three", "30", 1), ("three", "60.0", 2),
                                                   ("three", "0.0000004", 0), ("ninety", None, 0)])
def test_rows_are_the_in_plane_cells_with_their_values(tables, tmp_path, capsys, name, theta_i, index):
    table = tables[name]
    out = tmp_path / "slice.csv"
    options = [] if theta_i is None else ["--theta-i", theta_i]
    assert export_csv(table, out, *options) == 0
    assert "wrote" in capsys.readouterr().out
    _, header, rows = read_rows(out)
    assert header == COLUMNS
    expected = expected_slice(table, index, order_slot=0, offset=0)
    assert len(rows) == len(expected) == table.sensor.resolution
    assert [int(r[2]) for r in rows] == [e[2] for e in expected]
    for got, want in zip(rows, expected):
        assert got[0] == pytest.approx(want[0], abs=1e-6)  # the stretch middle, deg
        assert got[1] == pytest.approx(want[1], abs=1e-9)
        assert got[3] == want[3] and got[4] == want[4]  # the table's values, bit for bit
    theta_o = [r[0] for r in rows]
    assert theta_o == sorted(theta_o) and theta_o[0] < -60.0 and theta_o[-1] > 60.0


def test_a_plane_along_a_cell_border_gives_both_sides(tables, tmp_path):
    table = tables["even"]
    out = tmp_path / "even.csv"
    assert export_csv(table, out) == 0
    _, _, rows = read_rows(out)
    expected = expected_slice(table, 0, order_slot=0, offset=1.0 / table.sensor.resolution)
    assert len(rows) == len(expected) == 2 * table.sensor.resolution
    got = sorted((round(r[0], 6), int(r[2]), r[1], r[3], r[4]) for r in rows)
    want = sorted((round(e[0], 6), e[2], e[1], e[3], e[4]) for e in expected)
    assert got == want
    assert len({r[3] for r in rows}) == len(rows)  # every cell its own value: none repeated


def test_order_selects_the_values(tables, tmp_path):
    table = tables["three"]
    out = tmp_path / "f1.csv"
    assert export_csv(table, out, "--theta-i", "30", "--order", "f1") == 0
    _, _, rows = read_rows(out)
    expected = expected_slice(table, 1, order_slot=1, offset=0)
    assert [(int(r[2]), r[3], r[4]) for r in rows] == [(e[2], e[3], e[4]) for e in expected]
    assert not np.allclose([r[3] for r in rows], table.brdf[1, 0, [e[2] for e in expected]])


def test_comments_say_where_the_slice_comes_from(tables, tmp_path):
    table = tables["three"]
    out = tmp_path / "slice.csv"
    assert export_csv(table, out, "--theta-i", "60", "--order", "1") == 0
    lines = out.read_text(encoding="utf-8").splitlines()
    first_data = next(n for n, line in enumerate(lines) if not line.startswith("#")) + 1
    comments, _, _ = read_rows(out)
    assert comments[0].startswith(f"vcavity {__version__}:")
    assert f"skiprows={first_data}" in comments[0] and f"{first_data} lines precede" in comments[0]
    text = "\n".join(comments)
    assert f"source table: {table.path.resolve()}" in text
    material = next(line for line in comments if line.startswith("material: "))
    assert json.loads(material[len("material: "):]) == table.material
    assert "theta_i_deg = 60, phi_i_deg = 0" in text
    assert "order = 1 " in text
    assert "1/sr" in text and "degrees" in text
    assert "< 0 toward the light (phi_o = phi_i)" in text


def test_readable_by_numpy_pandas_and_csv(tables, tmp_path):
    table = tables["three"]
    out = tmp_path / "slice.csv"
    assert export_csv(table, out, "--theta-i", "30") == 0
    first = out.read_text(encoding="utf-8").splitlines()[0]
    skiprows = int(first.split("skiprows=")[1].rstrip(")"))
    array = np.loadtxt(out, delimiter=",", skiprows=skiprows)
    _, _, rows = read_rows(out)
    np.testing.assert_array_equal(array, np.array(rows))
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(out, comment="#")
    assert list(frame.columns) == COLUMNS
    np.testing.assert_array_equal(frame.to_numpy(), array)


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("name, options, message", [
    ("three", ["--theta-i", "30", "--order", "2"], "has orders 0 (f_inf), 1"),
    ("three", ["--theta-i", "45"], "--theta-i = 45: not an incident direction of table"),
    ("three", ["--theta-i", "45"], "(theta_i_deg: 0, 30, 60)"),
    ("three", ["--theta-i", "thirty"], "--theta-i = 'thirty': expected an angle in degrees"),
    ("three", [], "has several incident directions (theta_i_deg: 0, 30, 60)"),
    ("azimuths", ["--theta-i", "30"], "2 incident directions at theta_i_deg = 30 (phi_i_deg: 0, 90)"),
])
def test_cli_refusals_are_one_line_and_touch_nothing(tables, tmp_path, capsys, name, options, message):
    out = tmp_path / "slice.csv"
    assert export_csv(tables[name], out, *options) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()
    out.write_text("an older file\n")
    before = _sha256(out)
    assert export_csv(tables[name], out, *options, "--overwrite") == 2
    assert message in capsys.readouterr().err
    assert _sha256(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slice.csv"]
