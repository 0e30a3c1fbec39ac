"""``vcavity plot`` and scripts/fig7.py: every kind renders for every table type, the
in-plane geometry against the kernel's own binning, the specular peak where it belongs,
and bad input as one-line errors with exit status 2.

Tables are made once per module by tiny runs of Beckmann + interfaced Lambertian
(kd > 0, eta = 1.5), the kernel variant the rest of the suite compiles.
"""

import importlib.util
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.plots.png_checks import assert_png
from vcavity import open_table
from vcavity.cli import main
from vcavity.plots import plot_table
from vcavity.plots.figures import _disk, _disk_mesh
from vcavity.sensor.plane import SIDE_OFFSET, plane_directions, plane_segments
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sensor.binning import cell_index

ROOT = Path(__file__).resolve().parents[2]


def _config(folder, name, alpha, theta, max_order, track_all, resolution, paths):
    path = folder / f"{name}.toml"
    path.write_text(
        f'[material]\ndistribution = "beckmann"\nalpha = {alpha}\nkd = 0.9\neta = 1.5\n'
        f"[incidence]\ntheta_i_deg = {theta}\nphi_i_deg = 0\npaths = {paths}\n"
        f"[simulation]\nseed = 5\nmax_order = {max_order}\n"
        f"track_all_orders = {'true' if track_all else 'false'}\nsensor_resolution = {resolution}\n")
    return path


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plot")
    specs = {  # name: (alpha, theta_i_deg, max_order, track_all_orders, N, paths)
        "fig7b": (0.6, "[0, 60]", 2, True, 17, 200_000),  # with f_inf, several theta_i
        "f_only": (0.6, "[45]", 2, False, 17, 100_000),  # no f_inf, one theta_i
        "sharp": (0.1, "[30, 60]", 2, True, 57, 200_000),  # near-specular lobe
    }
    paths = {}
    for name, spec in specs.items():
        paths[name] = folder / f"{name}.h5"
        assert main(["run", str(_config(folder, name, *spec)), "-o", str(paths[name]), "-q"]) == 0
    return paths


@pytest.mark.parametrize("kind", ["slice", "map", "albedo"])
@pytest.mark.parametrize("name", ["fig7b", "f_only"])
def test_every_kind_renders_for_every_table_type(tables, tmp_path, capsys, kind, name):
    out = tmp_path / f"{name}_{kind}.png"
    assert main(["plot", str(tables[name]), "--kind", kind, "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert_png(out)


def test_log_map_and_default_output_beside_the_table(tables, capsys):
    assert main(["plot", str(tables["fig7b"]), "--kind", "map", "--scale", "log", "--theta-i", "60",
                 "--order", "f1", "inf"]) == 0
    out = tables["fig7b"].with_name("fig7b_map.png")
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert_png(out)


def test_map_albedo_and_model_free_slices_import_no_numba(tables, tmp_path):
    """Only the analytic overlays need Numba; the other plots work where it is not wanted."""
    script = ("import sys\nfrom vcavity.cli import main\n"
              f"table, out = {str(tables['fig7b'])!r}, {str(tmp_path)!r}\n"
              "assert main(['plot', table, '--kind', 'map', '-o', out + '/m.png']) == 0\n"
              "assert main(['plot', table, '--kind', 'albedo', '-o', out + '/a.png']) == 0\n"
              "assert main(['plot', table, '--no-models', '-o', out + '/s.png']) == 0\n"
              "print('numba' in sys.modules)\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "False"


@pytest.mark.parametrize("resolution, phi", [(17, 0.0), (8, 0.0), (9, 0.7), (8, np.pi / 4)])
def test_plane_segments_agree_with_the_kernel_binning(resolution, phi):
    """Both probes of every stretch (its middle and points near both ends, either side of
    the plane) land, by the kernel's own binning, in the cells the stretch names; the
    stretches tile [-90, 90] deg in the plane of incidence. N = 8 at phi = 0 runs the plane
    along cell borders (both sides differ)."""
    sensor = EqualAreaSensor(resolution)
    seg = plane_segments(resolution, phi)
    assert seg.edges[0] == -90.0 and seg.edges[-1] == 90.0 and np.all(np.diff(seg.edges) > 0)
    width = np.diff(seg.edges)
    for where in (0.5, 0.02, 0.98):
        t = seg.edges[:-1] + where * width
        for side, column in ((-SIDE_OFFSET, 0), (SIDE_OFFSET, 1)):
            binned = cell_index(sensor, plane_directions(t, phi, side))
            np.testing.assert_array_equal(binned, seg.cells[:, column])
    if resolution == 8 and phi == 0.0:
        assert np.all(seg.cells[:, 0] != seg.cells[:, 1])
    # t > 0 is the specular side, phi_o = phi_i + 180 deg
    o = plane_directions(np.array([40.0, -40.0]), phi)
    s = np.sin(np.radians(40.0))
    np.testing.assert_allclose(o[:, :2], [[-s * np.cos(phi), -s * np.sin(phi)],
                                          [s * np.cos(phi), s * np.sin(phi)]], atol=1e-12)


def test_map_mesh_is_the_sensor_cells_on_the_equal_area_disk():
    """Quad [iy, ix] of the drawn mesh surrounds the disk image of cell iy N + ix's centre
    (a transposed or flipped mesh would misplace the lobes)."""
    n = 9
    x, y = _disk_mesh(n)
    quad_x = 0.25 * (x[:-1, :-1] + x[1:, :-1] + x[:-1, 1:] + x[1:, 1:])
    quad_y = 0.25 * (y[:-1, :-1] + y[1:, :-1] + y[:-1, 1:] + y[1:, 1:])
    cx, cy = _disk(EqualAreaSensor(n).cell_center)
    # a third of a cell side 2/n: a misplaced quad is at least a whole side away
    assert np.max(np.hypot(quad_x.ravel() - cx, quad_y.ravel() - cy)) < (2.0 / n) / 3.0
    np.testing.assert_allclose(np.hypot(cx, cy) ** 2, 1.0 - EqualAreaSensor(n).cell_center[:, 2],
                               atol=1e-12)  # radius^2 = 1 - cos(theta): equal-area


@pytest.mark.slow  # ~20 s: runs in CI's slow suite (keeps the default suite under 10 min)
def test_specular_peak_sits_at_the_mirror_direction(tables, tmp_path):
    """Beckmann alpha = 0.1, eta = 1.5: the f1 slice peaks in the stretch holding
    theta_o = theta_i or its neighbour (one cell), not on the light side; there the V-cavity
    model of the same cells agrees with the table (|z| < 4.5: false alarm 7e-6 per
    direction, normal approximation of about 2e3 counts)."""
    datas = plot_table(tables["sharp"], "slice", tmp_path / "sharp.png")
    assert_png(tmp_path / "sharp.png")
    assert [d.theta_i_deg for d in datas] == [30.0, 60.0]
    for d in datas:
        f1 = d.brdf[1]
        k = int(np.argmax(f1))
        low, high = d.edges[k], d.edges[k + 1]
        assert low - (high - low) <= d.theta_i_deg <= high + (high - low), (d.theta_i_deg, low, high)
        back = np.searchsorted(d.edges, -d.theta_i_deg) - 1
        assert f1[k] > 2.0 * f1[back]
        z = (f1[k] - d.models["vcavity"][k]) / d.stderr[1][k]
        assert abs(z) < 4.5, z
        assert int(np.argmax(d.models["vcavity"])) in (k - 1, k, k + 1)


def test_albedo_data_share_from_counts(tables, tmp_path):
    data = plot_table(tables["fig7b"], "albedo", tmp_path / "a.png")
    t = open_table(tables["fig7b"])
    n_inf = t.counts[:, t.order_index(0)].sum(axis=1)
    n_1 = t.counts[:, t.order_index(1)].sum(axis=1)
    np.testing.assert_allclose(data.share, 1.0 - n_1 / n_inf, rtol=1e-12)
    np.testing.assert_allclose(data.albedo[2], t.counts[:, t.order_index(2)].sum(axis=1) / t.paths, rtol=1e-12)
    assert data.share_stderr is not None and np.all(data.share_stderr > 0)


BAD = [
    (["--kind", "bogus"], "--kind = 'bogus': accepted slice, map, albedo, sweep, versus"),
    (["--kind", "sweep"], "--kind = 'sweep': fig7b.h5 is a table of one run; --kind sweep draws a sweep file"),
    (["-o", "{tmp}/missing/x.png"], "does not exist"),
    (["-o", "{tmp}/x.bmp"], "unsupported file type '.bmp'"),
    (["--theta-i", "45"], "--theta-i = 45: not an incident direction"),
    (["--theta-i", "abc"], "--theta-i = 'abc'"),
    (["--order", "3"], "--order = 3: table fig7b.h5 has orders 0 (f_inf), 1, 2"),
    (["--order", "two"], "--order = 'two'"),
    (["--scale", "cubic"], "--scale = 'cubic': accepted log, linear"),
    (["--kind", "albedo", "--scale", "log"], "--scale = 'log'"),
]


@pytest.mark.parametrize("arguments, message", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tables, tmp_path, capsys, arguments, message):
    arguments = [a.replace("{tmp}", str(tmp_path)) for a in arguments]
    before = sorted(tables["fig7b"].parent.iterdir())
    assert main(["plot", str(tables["fig7b"]), *arguments]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: ") and message in lines[0], lines
    assert sorted(tables["fig7b"].parent.iterdir()) == before and list(tmp_path.iterdir()) == []


def _snapshot(folder):
    """Each entry of ``folder``: a link's target, a file's bytes, else its kind (links not followed)."""
    seen = {}
    for entry in sorted(folder.iterdir()):
        mode = stat.S_IFMT(entry.lstat().st_mode)
        seen[entry.name] = (os.readlink(entry) if mode == stat.S_IFLNK else
                            entry.read_bytes() if mode == stat.S_IFREG else mode)
    return seen


@pytest.fixture
def plot_box(tables, tmp_path):
    """A table, old images, a link, a FIFO and a folder named like images, the table as t.png."""
    shutil.copyfile(tables["fig7b"], tmp_path / "t.h5")
    os.link(tmp_path / "t.h5", tmp_path / "t.png")  # a table whose name ends in .png
    (tmp_path / "old.png").write_bytes(b"an older image")
    (tmp_path / "t_albedo.png").write_bytes(b"an older default image")
    os.symlink("old.png", tmp_path / "link.png")
    os.mkfifo(tmp_path / "fifo.png")
    (tmp_path / "d.png").mkdir()
    return tmp_path


OUTPUT_RULES = [
    (["t.h5", "-o", "link.png", "--overwrite"], "-o = 'link.png': is a symbolic link (to 'old.png')"),
    (["t.h5", "-o", "fifo.png", "--overwrite"], "-o = 'fifo.png': exists and is a FIFO (named pipe)"),
    (["t.h5", "-o", "d.png", "--overwrite"], "-o = 'd.png': is a directory"),
    (["t.png", "-o", "t.png", "--overwrite"], "-o = 't.png': is the input 't.png' itself"),
    (["t.h5", "-o", "t.png", "--overwrite"], "-o = 't.png': is the input 't.h5' itself"),  # a hard link
    (["t.h5", "-o", "old.png"], "-o = 'old.png': exists; pass --overwrite to replace it"),
    (["t.h5"], "output (default: <input>_albedo.png beside the input) = 't_albedo.png': exists; pass --overwrite"),
]


@pytest.mark.parametrize("arguments, message", OUTPUT_RULES, ids=[" ".join(a) for a, _ in OUTPUT_RULES])
def test_the_output_rules_of_run_and_export(plot_box, monkeypatch, arguments, message):
    """As a shell sees it (a FIFO once blocked or gave a traceback): exit 2, one line, nothing touched."""
    monkeypatch.chdir(plot_box)
    before = _snapshot(plot_box)
    done = subprocess.run([sys.executable, "-m", "vcavity.cli", "plot", *arguments, "--kind", "albedo"],
                          cwd=plot_box, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == "", done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"vcavity: error: {message}"), lines
    assert _snapshot(plot_box) == before


def test_overwrite_replaces_a_file_atomically(plot_box, monkeypatch, capsys):
    monkeypatch.chdir(plot_box)
    assert main(["plot", "t.h5", "--kind", "albedo", "-o", "old.png", "--overwrite"]) == 0
    assert capsys.readouterr().out.strip() == "wrote old.png"
    assert_png(plot_box / "old.png")
    assert os.readlink("link.png") == "old.png" and (plot_box / "t.png").read_bytes()[:4] == b"\x89HDF"
    assert not [p for p in os.listdir(plot_box) if p.endswith(".tmp")]


def test_table_without_f_inf_and_missing_table(tables, tmp_path, capsys):
    assert main(["plot", str(tables["f_only"]), "--order", "inf"]) == 2
    assert "track_all_orders = true" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "none.h5")]) == 2
    assert capsys.readouterr().err.strip() == f"vcavity: error: table '{tmp_path / 'none.h5'}': no such file"


def test_plot_help_answers_questions(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["plot", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for needle in ("slice", "map", "albedo", "sweep", "a sweep file", "1/sr", "--theta-i", "--order",
                   "f_inf", "--scale", "log", "equal-area", "+-2 standard errors", "phi_o = phi_i + 180",
                   "scripts/fig7.py"):
        assert needle in text, needle


@pytest.mark.slow  # ~20 s: runs in CI's slow suite (keeps the default suite under 10 min)
def test_fig7_script(tables, tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("fig7", ROOT / "scripts" / "fig7.py")
    fig7 = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fig7)
    out = tmp_path / "fig7.png"
    assert fig7.main([str(tables["fig7b"]), str(tables["sharp"]), "--theta-i", "60", "-o", str(out)]) == 0
    assert_png(out)
    assert fig7.main([str(tables["fig7b"]), "-o", str(tmp_path / "no" / "f.png")]) == 2
    assert fig7.main([str(tables["f_only"]), "-o", str(out), "--overwrite"]) == 2  # default orders include f_inf
    assert "fig7: error: --order = f_inf" in capsys.readouterr().err
