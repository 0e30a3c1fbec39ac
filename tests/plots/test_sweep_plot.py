"""``vcavity plot SWEEP.h5`` (kind sweep): the plotted numbers are the sweep's albedo at the
right coordinates, the error bars the binomial error of the right direction, the figure
renders, and what cannot be drawn is a one-line error with exit status 2.

No simulation: the sweeps are written with albedos chosen here
(tests/export/synthetic_sweeps.py) and read back for the expected values with xarray
(h5netcdf), a reader independent of vcavity's. Every check is exact: nothing statistical.
"""

import hashlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests.plots.png_checks import assert_png
from tests.export.synthetic_sweeps import synthetic_sweep
from vcavity.cli import main
from vcavity.plots import plot_table

ALPHA = [0.7, 0.1, 0.4, 1.0]  # not ascending: the plot sorts the x axis
ETA = [1.0, 1.5, 2.0]
THETA = [0.0, 60.0]


def _uniform(coords, order):
    key = repr(sorted(coords.items())) + f"|{order}"
    return int.from_bytes(hashlib.sha256(key.encode()).digest()[:4], "little") / 2**32


def _albedo(coords, order):
    """A different value at every grid position and order (a swap of any two shows), with
    f_inf = f1 + f2 + f3 + more, as a walk's albedos are."""
    scale = {1: 0.6, 2: 0.2, 3: 0.1}
    if order:
        return scale[order] * _uniform(coords, order)
    return sum(_albedo(coords, k) for k in scale) + 0.05 * _uniform(coords, 0)


def _paths(coords):
    """Paths differ per direction, so an error bar computed with another direction's paths shows."""
    return 10_000 + 1_000 * ETA.index(coords["eta"]) + 37 * THETA.index(coords["theta_i_deg"]) \
        + 5 * ALPHA.index(coords["alpha"])


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep_plot")
    axes = [("alpha", ALPHA), ("eta", ETA), ("kd", [0.9]), ("theta_i_deg", THETA)]
    return {
        "grid": synthetic_sweep(folder / "grid.h5", axes, _albedo, orders=(0, 1, 2, 3), paths=_paths),
        "pending": synthetic_sweep(folder / "pending.h5", axes, _albedo, paths=_paths, pending=[{"eta": 2.0}]),
        "paper": synthetic_sweep(folder / "paper.h5", axes, _albedo, paths=_paths, estimator="paper"),
        "exact": synthetic_sweep(folder / "exact.h5", axes, _albedo, paths=_paths, estimator="exact-f1"),
        "phi": synthetic_sweep(folder / "phi.h5", [("distribution", ["beckmann", "ggx"]), ("alpha", [0.2, 0.5]),
                                                   ("theta_i_deg", [30.0]), ("phi_i_deg", [0.0, 90.0])],
                               _albedo, orders=(0, 1), paths=20_000),
        "sigma": synthetic_sweep(folder / "sigma.h5", [("sigma", [0.3, 0.1]), ("theta_i_deg", [0.0])], _albedo,
                                 orders=(0, 1), material={"distribution": "gaussian", "facet": "interfaced_lambertian",
                                                          "kd": 0.9, "eta": 1.5}),
        "no_roughness": synthetic_sweep(folder / "eta_only.h5", [("eta", ETA), ("theta_i_deg", THETA)], _albedo),
    }


def _expected(path, panel, line, order, by="alpha"):
    """Albedo and binomial stderr along ``by`` (ascending) at a panel and line, read by xarray."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        where = {**panel, **line, "order": order}
        where.update({name: ds[name].values[0] for name in ds.albedo.dims
                      if name not in where and name != by and ds.sizes[name] == 1})
        a = ds.albedo.sel(where).sortby(by)
        n = ds.paths.sel({k: v for k, v in where.items() if k != "order"}).sortby(by)
        return a[by].values, a.values, np.sqrt(a.values * (1.0 - a.values) / n.values)


def test_a_sweep_file_is_drawn_as_kind_sweep_by_default(sweeps, capsys):
    assert main(["plot", str(sweeps["grid"])]) == 0
    out = sweeps["grid"].with_name("grid_sweep.png")
    assert capsys.readouterr().out.strip() == f"wrote {out}"
    assert_png(out)


def test_plotted_numbers_are_the_sweep_albedo_and_binomial_error(sweeps, tmp_path):
    data = plot_table(sweeps["grid"], output=tmp_path / "g.png")
    assert data.roughness == "alpha" and data.orders == (1, 0)  # default: f1 and f_inf
    np.testing.assert_array_equal(data.roughness_values, sorted(ALPHA))
    assert data.panels == [{"theta_i_deg": 0.0}, {"theta_i_deg": 60.0}]
    assert data.lines == [{"eta": 1.0}, {"eta": 1.5}, {"eta": 2.0}]  # kd has one value: no line of its own
    for i, panel in enumerate(data.panels):
        for j, line in enumerate(data.lines):
            for k in data.orders:
                alpha, albedo, stderr = _expected(sweeps["grid"], panel, line, k)
                np.testing.assert_array_equal(alpha, data.roughness_values)
                np.testing.assert_array_equal(data.albedo[k][i, j], albedo)
                np.testing.assert_allclose(data.stderr[k][i, j], stderr, rtol=1e-12)


def test_theta_i_and_order_choose_panels_and_curves(sweeps, tmp_path, capsys):
    out = tmp_path / "o.png"
    assert main(["plot", str(sweeps["grid"]), "--kind", "sweep", "--theta-i", "60", "--order", "inf", "2",
                 "-o", str(out)]) == 0
    assert_png(out)
    data = plot_table(sweeps["grid"], "sweep", tmp_path / "o2.png", theta_i_deg=["60"], orders=["inf", "2"])
    assert data.panels == [{"theta_i_deg": 60.0}] and data.orders == (2, 0)
    _, albedo, _ = _expected(sweeps["grid"], {"theta_i_deg": 60.0}, {"eta": 1.5}, 2)
    np.testing.assert_array_equal(data.albedo[2][0, 1], albedo)


def test_incidence_azimuth_and_a_text_axis(sweeps, tmp_path):
    """phi_i_deg swept: one panel per (theta_i, phi_i); distribution: one line per name."""
    data = plot_table(sweeps["phi"], output=tmp_path / "p.png")
    assert_png(tmp_path / "p.png")
    assert data.panels == [{"theta_i_deg": 30.0, "phi_i_deg": 0.0}, {"theta_i_deg": 30.0, "phi_i_deg": 90.0}]
    assert data.lines == [{"distribution": "beckmann"}, {"distribution": "ggx"}]
    for i, panel in enumerate(data.panels):
        for j, line in enumerate(data.lines):
            for k in (0, 1):
                _, albedo, _ = _expected(sweeps["phi"], panel, line, k)
                np.testing.assert_array_equal(data.albedo[k][i, j], albedo)


def test_other_roughness_axes_are_the_x_axis(sweeps, tmp_path):
    data = plot_table(sweeps["sigma"], output=tmp_path / "s.png")
    assert data.roughness == "sigma"
    sigma, albedo, _ = _expected(sweeps["sigma"], {"theta_i_deg": 0.0}, {}, 0, by="sigma")
    np.testing.assert_array_equal(data.roughness_values, sigma)
    np.testing.assert_array_equal(data.albedo[0][0, 0], albedo)


def test_points_not_done_are_gaps(sweeps, tmp_path):
    data = plot_table(sweeps["pending"], output=tmp_path / "n.png")
    assert_png(tmp_path / "n.png")
    for k in data.orders:
        assert np.all(np.isnan(data.albedo[k][:, 2])) and np.all(np.isfinite(data.albedo[k][:, :2]))
    _, albedo, _ = _expected(sweeps["pending"], {"theta_i_deg": 0.0}, {"eta": 1.5}, 1)
    np.testing.assert_array_equal(data.albedo[1][0, 1], albedo)
    assert "4 of 12 points not done (gaps)" in data.notes


def test_error_bars_follow_the_estimator(sweeps, tmp_path):
    """paper: no albedo error is stored, so no error bars; exact-f1: f1 is analytic (none),
    f_inf's error is the binomial one of the simulated part albedo_inf - albedo_1."""
    paper = plot_table(sweeps["paper"], output=tmp_path / "w.png")
    assert paper.stderr == {1: None, 0: None} and any("no error bars" in n for n in paper.notes)
    assert_png(tmp_path / "w.png")
    exact = plot_table(sweeps["exact"], output=tmp_path / "e.png")
    assert exact.stderr[1] is None
    panel, line = {"theta_i_deg": 60.0}, {"eta": 1.0}
    _, a_inf, _ = _expected(sweeps["exact"], panel, line, 0)
    _, a_1, _ = _expected(sweeps["exact"], panel, line, 1)
    with xr.open_dataset(sweeps["exact"], engine="h5netcdf") as ds:
        n = ds.paths.sel(theta_i_deg=60.0, eta=1.0, kd=0.9).sortby("alpha").values
    p = a_inf - a_1
    np.testing.assert_allclose(exact.stderr[0][1, 0], np.sqrt(p * (1 - p) / n), rtol=1e-12)


BAD = [
    ("grid", ["--kind", "slice"], "--kind = 'slice': grid.h5 is a sweep file (vcavity sweep), drawn with --kind sweep"),
    ("grid", ["--kind", "map"], "drawn with --kind sweep"),
    ("grid", ["--kind", "albedo"], "slice, map and albedo draw a table of vcavity run"),
    ("grid", ["--scale", "log"], "--scale = 'log': applies to --kind slice, map and versus; sweep plots are linear"),
    ("grid", ["--order", "5"], "--order = 5: sweep grid.h5 has orders 0 (f_inf), 1, 2, 3"),
    ("grid", ["--theta-i", "45"], "--theta-i = 45: not an incident direction of sweep grid.h5 (theta_i_deg: 0, 60)"),
    ("grid", ["-o", "{tmp}/x.bmp"], "unsupported file type '.bmp'"),
    ("no_roughness", [], "sweep eta_only.h5 has no roughness axis (axes: eta, theta_i_deg)"),
]


@pytest.mark.parametrize("name, arguments, message", BAD, ids=[f"{n} {' '.join(a)}" for n, a, _ in BAD])
def test_bad_requests_are_one_line_exit_2_and_write_nothing(sweeps, tmp_path, capsys, name, arguments, message):
    arguments = [a.replace("{tmp}", str(tmp_path)) for a in arguments]
    before = sorted(sweeps[name].parent.iterdir())
    assert main(["plot", str(sweeps[name]), *arguments]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: ") and message in lines[0], lines
    assert sorted(sweeps[name].parent.iterdir()) == before and list(tmp_path.iterdir()) == []


def test_plotting_a_sweep_imports_no_numba(sweeps, tmp_path):
    script = ("import sys\nfrom vcavity.cli import main\n"
              f"assert main(['plot', {str(sweeps['grid'])!r}, '-o', {str(tmp_path / 'x.png')!r}]) == 0\n"
              "print('numba' in sys.modules)\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[2])
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "False"


def test_a_swept_microsurface_is_a_line_not_the_shared_material(tmp_path):
    from vcavity.io.sweep_table import open_sweep
    from vcavity.plots.sweep import sweep_data, sweep_figure

    path = synthetic_sweep(tmp_path / "m.h5", [("microsurface", ["v-cavity", "smith"]), ("alpha", [0.2, 0.5]),
                                               ("theta_i_deg", [0.0])], _albedo, orders=(0, 1))
    sweep = open_sweep(path)
    data = sweep_data(sweep, [0], (1, 0))
    title = sweep_figure(sweep, data).get_suptitle()
    assert data.lines == [{"microsurface": "v-cavity"}, {"microsurface": "smith"}]
    assert "microsurface," not in title and "beckmann, interfaced_lambertian facets" in title
