"""``vcavity plot A.h5 B.h5 --kind versus``: the plotted numbers are the two tables' own
(albedo, in-plane cell values, errors) at the same incident direction, the differences
are ``B - A`` with the quadrature sum of the standard errors, two points of a sweep file
are read at the right coordinates, and the figure has a value and a difference panel per
direction.

No simulation: tables of random counts and sweeps of random values
(tests/plots/versus_inputs.py), read back for the expected values with h5py and xarray,
independent of vcavity's readers. Every check is exact: nothing statistical.
"""

import h5py
import numpy as np
import pytest
import xarray as xr

from tests.plots.png_checks import assert_png
from tests.plots.versus_inputs import MATERIAL, random_sweep, random_table
from vcavity.plots import check_request, plot_table
from vcavity.plots import versus as versus_kind

THETA_A = [0.0, 30.0, 60.0, 80.0]
THETA_B = [80.0, 0.0, 45.0, 30.0]  # another order, one angle A lacks, one A has that B lacks
COMMON = [0.0, 30.0, 80.0]  # in A's order


# odd N: the plane of incidence (phi_i = 0) runs through cells; even N: along cell borders
@pytest.fixture(scope="module", params=[9, 8])
def pair(tmp_path_factory, request):
    folder = tmp_path_factory.mktemp("versus")
    a = random_table(folder / "vcav.h5", THETA_A, seed=1, resolution=request.param)
    b = random_table(folder / "smith.h5", THETA_B, seed=2, material={"microsurface": "smith", **MATERIAL},
                     resolution=request.param)
    return a, b


def _data(table, output, **options):
    """What ``plot_table(table, "versus", output, **options)`` plots, without drawing it."""
    from vcavity.plots import _opened

    if "second" in options:
        options["second"] = _opened(options["second"])
    request = check_request(_opened(table), "versus", output, **options)
    return versus_kind.versus_data(*request.sides, request.indices, request.orders, request.differs)


def _read(path):
    """The datasets a versus plot uses, read with h5py alone."""
    with h5py.File(path, "r") as h5:
        return {name: h5[name][()] for name in ("theta_i_deg", "order", "albedo", "paths", "brdf", "brdf_stderr")}


def _row(table, theta):
    return int(np.flatnonzero(table["theta_i_deg"] == theta)[0])


def _slot(table, k):
    return int(np.flatnonzero(table["order"] == k)[0])


def test_albedo_and_its_difference_are_the_tables_at_the_same_theta(pair, tmp_path):
    data = _data(pair[0], tmp_path / "v.png", second=pair[1])
    a, b = _read(pair[0]), _read(pair[1])
    assert list(data.theta_i_deg) == COMMON
    assert data.orders == (1, 2, 0)
    for k in data.orders:
        for i, theta in enumerate(COMMON):
            ja, jb = _row(a, theta), _row(b, theta)
            alb_a, alb_b = a["albedo"][ja, _slot(a, k)], b["albedo"][jb, _slot(b, k)]
            err_a = np.sqrt(alb_a * (1 - alb_a) / a["paths"][ja])
            err_b = np.sqrt(alb_b * (1 - alb_b) / b["paths"][jb])
            assert data.albedo[0][k][i] == pytest.approx(alb_a, rel=1e-12)
            assert data.albedo[1][k][i] == pytest.approx(alb_b, rel=1e-12)
            assert data.albedo_stderr[1][k][i] == pytest.approx(err_b, rel=1e-12)
            assert data.albedo_difference[k][i] == pytest.approx(alb_b - alb_a, rel=1e-12, abs=1e-15)
            assert data.albedo_difference_stderr[k][i] == pytest.approx(np.hypot(err_a, err_b), rel=1e-12)


def test_slice_difference_is_b_minus_a_cell_by_cell_with_quadrature_errors(pair, tmp_path):
    data = _data(pair[0], tmp_path / "v.png", second=pair[1], orders=["1", "3", "inf"])
    a, b = _read(pair[0]), _read(pair[1])
    assert len(data.slices) == len(COMMON)
    for (first, second), diff, err, theta in zip(data.slices, data.difference, data.difference_stderr, COMMON):
        assert first.theta_i_deg == second.theta_i_deg == theta
        np.testing.assert_array_equal(first.cells, second.cells)
        c0, c1 = first.cells[:, 0], first.cells[:, 1]
        both = c0 != c1  # a stretch along a cell border: the mean of the cells either side
        for k in (1, 3, 0):
            values, errors = [], []
            for t in (a, b):
                j, s = _row(t, theta), _slot(t, k)
                f, e = t["brdf"][j, s], t["brdf_stderr"][j, s]
                values.append(0.5 * (f[c0] + f[c1]))
                errors.append(np.where(both, 0.5 * np.sqrt(e[c0] ** 2 + e[c1] ** 2), e[c0]))
            np.testing.assert_allclose(first.brdf[k], values[0], rtol=1e-12)
            np.testing.assert_allclose(second.brdf[k], values[1], rtol=1e-12)
            np.testing.assert_allclose(diff[k], values[1] - values[0], rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(err[k], np.sqrt(errors[0] ** 2 + errors[1] ** 2), rtol=1e-12)


def test_theta_i_picks_common_directions(pair, tmp_path):
    data = _data(pair[0], tmp_path / "v.png", second=pair[1], theta_i_deg=["80"])
    assert list(data.theta_i_deg) == [80.0] and len(data.slices) == 1
    assert data.slices[0][1].index == THETA_B.index(80.0)


def test_the_figure_has_an_albedo_pair_and_a_slice_pair_per_direction(pair, tmp_path):
    from vcavity.io.table import open_table

    out = tmp_path / "v.png"
    plot_table(pair[0], "versus", out, second=pair[1])
    assert_png(out)
    request = check_request(open_table(pair[0]), "versus", tmp_path / "w.png", second=open_table(pair[1]))
    fig, data = versus_kind.render(None, request)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 2 * (1 + len(data.slices))
    titles = [ax.get_title() for ax in visible]
    assert sum("theta_i = " in t for t in titles) == len(COMMON)
    assert "smith" in fig._suptitle.get_text() and "v-cavity" in fig._suptitle.get_text()


SWEEP_AXES = [("alpha", [0.1, 0.5, 1.0]), ("theta_i_deg", [60.0, 0.0]), ("microsurface", ["v-cavity", "smith"])]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    return random_sweep(tmp_path_factory.mktemp("versus_sweep") / "s.h5", SWEEP_AXES,
                        pending=[{"alpha": 1.0, "microsurface": "smith"}])


@pytest.mark.parametrize("versus, labels", [(None, ("v-cavity", "smith")),
                                            ("microsurface=smith,v-cavity", ("smith", "v-cavity"))])
def test_two_points_of_a_sweep_are_read_at_their_coordinates(sweep, tmp_path, versus, labels):
    data = plot_table(sweep, "versus", tmp_path / "v.png", points=["alpha=0.5"], versus=versus,
                      orders=["1", "2", "inf"])
    assert sorted(data.theta_i_deg) == [0.0, 60.0]
    with xr.open_dataset(sweep, engine="h5netcdf") as ds:
        for i, theta in enumerate(data.theta_i_deg):
            at = [dict(alpha=0.5, theta_i_deg=theta, microsurface=m) for m in labels]
            for k in (1, 2, 0):
                alb = [float(ds.albedo.sel(order=k, **p)) for p in at]
                n = [float(ds.paths.sel(**p)) for p in at]
                assert data.albedo_difference[k][i] == pytest.approx(alb[1] - alb[0], rel=1e-12)
                errs = [np.sqrt(x * (1 - x) / m) for x, m in zip(alb, n)]
                assert data.albedo_difference_stderr[k][i] == pytest.approx(np.hypot(*errs), rel=1e-12)
                cells = data.slices[i][0].cells
                f = [ds.brdf.sel(order=k, **p).values for p in at]
                expected = [0.5 * (x[cells[:, 0]] + x[cells[:, 1]]) for x in f]
                np.testing.assert_allclose(data.difference[i][k], expected[1] - expected[0], rtol=1e-12,
                                           atol=1e-15)
    assert data.labels == tuple(f"microsurface = {m}" for m in labels)
    assert data.differs == {}


def test_another_axis_can_be_compared(sweep, tmp_path):
    data = _data(sweep, tmp_path / "v.png", points=["microsurface=v-cavity"],
                      versus="alpha=1.0,0.1", orders=["2"])
    with xr.open_dataset(sweep, engine="h5netcdf") as ds:
        for i, theta in enumerate(data.theta_i_deg):
            alb = [float(ds.albedo.sel(order=2, alpha=x, theta_i_deg=theta, microsurface="v-cavity"))
                   for x in (1.0, 0.1)]
            assert data.albedo_difference[2][i] == pytest.approx(alb[1] - alb[0], rel=1e-12)


def test_the_albedo_panel_draws_one_line_per_azimuth(tmp_path):
    from vcavity.io.table import open_table

    theta, phi = [30.0, 60.0, 30.0, 60.0, 0.0], [0.0, 0.0, 90.0, 90.0, 45.0]
    a = open_table(random_table(tmp_path / "a.h5", theta, seed=7, phi_deg=phi))
    b = open_table(random_table(tmp_path / "b.h5", theta[::-1], seed=8, phi_deg=phi[::-1]))
    request = check_request(a, "versus", tmp_path / "v.png", second=b, orders=["1", "inf"])
    fig, data = versus_kind.render(None, request)
    assert len(data.slices) == 5  # every direction of A is in B, found by theta_i and phi_i
    for (first, second), phi_i in zip(data.slices, phi):
        assert first.phi_i_deg == second.phi_i_deg == phi_i and first.theta_i_deg == second.theta_i_deg
    # the data lines of errorbar (its caps are marker-only lines)
    lines = [line for line in fig.axes[0].get_lines() if line.get_linestyle() != "None"]
    # per azimuth (3), order (2) and side (2) one line through its directions, in theta order
    assert len(lines) == 3 * 2 * 2
    for line in lines:
        assert np.all(np.diff(np.asarray(line.get_xdata())) > 0)
    assert sorted(len(line.get_xdata()) for line in lines) == [1] * 4 + [2] * 8


def test_the_microsurface_table_script_prints_the_sweeps_differences(tmp_path, capsys):
    """scripts/microsurface_table.py (the numbers of docs/microsurfaces.md) against xarray."""
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("microsurface_table", root / "scripts" / "microsurface_table.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    path = random_sweep(tmp_path / "m.h5", [("microsurface", ["smith", "v-cavity"]), ("alpha", [0.3, 0.6]),
                                             ("theta_i_deg", [0.0, 80.0])], seed=11)
    assert script.main([str(path), "--alpha", "0.6"]) == 0
    printed = capsys.readouterr().out.splitlines()
    rows = [line for line in printed if line.strip()[:1].isdigit() and "|" in line]
    assert len(rows) == 4
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        for row in rows:
            head, *cells = row.split("|")
            theta, alpha = (float(x) for x in head.split())
            for k, cell in zip((1, 2, 0), cells):
                v, s, d, e = (float(x) for x in cell.split())
                at = {m: dict(microsurface=m, alpha=alpha, theta_i_deg=theta) for m in ("v-cavity", "smith")}
                a = {m: float(ds.albedo.sel(order=k, **p)) for m, p in at.items()}
                n = {m: float(ds.paths.sel(**p)) for m, p in at.items()}
                sigma = np.hypot(*(np.sqrt(a[m] * (1 - a[m]) / n[m]) for m in at))
                assert (v, s) == pytest.approx((a["v-cavity"], a["smith"]), abs=5e-5)
                assert d == pytest.approx(a["smith"] - a["v-cavity"], abs=5e-5)
                assert e == pytest.approx(2 * sigma, abs=5e-5)
