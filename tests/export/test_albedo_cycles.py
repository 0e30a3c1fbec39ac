"""``vcavity export SWEEP.h5 OUT --format albedo-lut --layout cycles`` and ``--orders``: the
tables are the sweep's albedos at Blender Cycles' 32 x 32 nodes in its order (data[y * 32 +
x], y the mu node, x the r = sqrt(alpha) node), E_avg integrates 2 mu E by Simpson (exact
for E quadratic in mu, within its error bound otherwise), the C header compiles and indexes
like Cycles, per-order tables add up to E, and a sweep off the grid is refused naming the
missing nodes.

The nodes are written out here from Cycles' rule (cycles_precompute.cpp: clamp(i/31, 1e-4,
1) for r and mu), not taken from vcavity. Synthetic sweeps (tests/export/synthetic_sweeps.py)
carry closed-form albedos; expected values are read with xarray. The real sweep at the end
is 32 x 32 directions of 64 paths of the kernel the suite already compiles.
"""

import math
import shutil
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests.export.synthetic_sweeps import synthetic_sweep
from vcavity.cli import main

RUNS = Path(__file__).resolve().parents[2] / "runs" / "sweep_albedo_lut_cycles.toml"
NODES = np.clip(np.arange(32) / 31, 1e-4, 1.0)  # Cycles' r and mu nodes
ALPHA = NODES ** 2
THETA = np.degrees(np.arccos(NODES))


def _coords(c):
    return math.cos(math.radians(c["theta_i_deg"])), c["alpha"]


def _albedo(c, order):
    """Closed forms, f_inf above the sum of the orders: f1 quadratic in mu (Simpson is exact:
    E_avg = (0.65 - 0.2 alpha) / 2); f_inf = 0.6 + 0.4 exp(-k (1 - mu)), k = 0.5 + alpha
    (E_avg = 0.6 + 0.8 ((k - 1) + exp(-k)) / k^2)."""
    mu, alpha = _coords(c)
    return {0: 0.6 + 0.4 * math.exp(-(0.5 + alpha) * (1 - mu)), 1: (0.5 + 0.3 * mu * mu - 0.2 * alpha) / 2,
            2: 0.1 * alpha * mu, 3: 0.02 + 0.01 * alpha}[order]


def _paths(c):
    mu, alpha = _coords(c)
    return 5000 + int(round(1000 * mu)) + int(round(300 * alpha))


@pytest.fixture(scope="module")
def sweeps(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cycles")
    rng = np.random.default_rng(1)
    alpha = [*ALPHA[rng.permutation(32)], 0.5]  # shuffled, and a value off the grid
    theta = [*THETA[::-1], 45.0]
    partial_alpha = [a for i, a in enumerate(ALPHA) if i != 5]
    partial_theta = [t for i, t in enumerate(THETA) if i not in (0, 31)]
    return {
        "grid": synthetic_sweep(folder / "grid.h5", [("theta_i_deg", theta), ("alpha", alpha)], _albedo,
                                orders=(0, 1, 2, 3), paths=_paths),
        "no_f3": synthetic_sweep(folder / "no_f3.h5", [("alpha", list(ALPHA)), ("theta_i_deg", list(THETA))],
                                 _albedo, orders=(0, 1, 2), paths=_paths),
        "mu_only": synthetic_sweep(folder / "mu_only.h5", [("alpha", list(ALPHA)), ("theta_i_deg", list(THETA[:-1]))],
                                   _albedo, paths=_paths),
        "partial": synthetic_sweep(folder / "partial.h5", [("alpha", partial_alpha), ("theta_i_deg", partial_theta)],
                                   _albedo, paths=_paths),
    }


def _export(source, out, *options):
    return main(["export", str(source), str(out), "--format", "albedo-lut", *options])


def _expected(path, order):
    """albedo and paths at [y, x] = (mu node, r node), by xarray selection of the node values."""
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        ds = ds.squeeze(drop=True).sortby("alpha").sortby("theta_i_deg")  # "nearest" needs sorted axes
        picked = ds.sel(alpha=ALPHA, theta_i_deg=THETA, method="nearest", tolerance=1e-12)
        albedo = picked.albedo.sel(order=order).transpose("theta_i_deg", "alpha").values
        return albedo, picked.paths.transpose("theta_i_deg", "alpha").values


def test_the_runs_file_lies_on_cycles_nodes():
    spec = tomllib.loads(RUNS.read_text())["sweep"]
    np.testing.assert_allclose(spec["alpha"], ALPHA, rtol=1e-14, atol=0)
    np.testing.assert_allclose(np.cos(np.radians(spec["theta_i_deg"])), NODES, rtol=0, atol=1e-13)


def test_npz_holds_the_albedos_at_the_nodes_in_cycles_order(sweeps, tmp_path, capsys):
    out = tmp_path / "c.npz"
    assert _export(sweeps["grid"], out, "--layout", "cycles") == 0
    assert capsys.readouterr().out.strip() == f"wrote {out} (albedo-lut, layout cycles, f_inf)"
    lut = np.load(out)
    np.testing.assert_array_equal(lut["r"], NODES)
    np.testing.assert_array_equal(lut["mu"], NODES)
    np.testing.assert_allclose(lut["alpha"], ALPHA, rtol=1e-14)
    for name, order in (("E", 0), ("E_f1", 1)):
        albedo, paths = _expected(sweeps["grid"], order)
        assert lut[name].shape == (32, 32)
        np.testing.assert_array_equal(lut[name], albedo)
        flat = lut[name].ravel()  # Cycles' data[y * 32 + x]
        for y, x in ((0, 31), (31, 0), (7, 20)):
            mu, alpha = NODES[y], ALPHA[x]
            assert flat[y * 32 + x] == pytest.approx(_albedo({"theta_i_deg": math.degrees(math.acos(mu)),
                                                               "alpha": alpha}, order), rel=1e-12)
        np.testing.assert_allclose(lut[f"{name}_stderr"], np.sqrt(albedo * (1 - albedo) / paths), rtol=1e-12)
    np.testing.assert_array_equal(lut["paths"], _expected(sweeps["grid"], 0)[1])


def _simpson_bound(m4):
    """Composite Simpson 1/3 over 28 of 31 intervals plus 3/8 over 3: h^4/180 (28 h) M + 3 h^5/80 M."""
    h = 1 / 31
    return (28 * h * h ** 4 / 180 + 3 * h ** 5 / 80) * m4


def test_E_avg_is_simpson_exact_for_quadratics_and_within_its_bound(sweeps, tmp_path):
    out = tmp_path / "a.npz"
    assert _export(sweeps["grid"], out, "--layout", "cycles") == 0
    lut = np.load(out)
    np.testing.assert_allclose(lut["E_avg_f1"], (0.65 - 0.2 * ALPHA) / 2, rtol=0, atol=1e-13)
    k = 0.5 + ALPHA
    exact = 0.6 + 0.8 * ((k - 1) + np.exp(-k)) / k ** 2
    m4 = 0.4 * 2 * (k ** 4 + 4 * k ** 3)  # max over mu of |d^4/dmu^4 0.4 2 mu exp(-k (1 - mu))|
    assert np.all(np.abs(lut["E_avg"] - exact) <= _simpson_bound(m4)), np.abs(lut["E_avg"] - exact).max()


def test_orders_add_up_to_E_in_both_layouts(sweeps, tmp_path, capsys):
    out = tmp_path / "o.npz"
    assert _export(sweeps["grid"], out, "--layout", "cycles", "--orders", "1", "2", "3", "inf") == 0
    assert "(albedo-lut, layout cycles, f1, f2, f3, f_inf)" in capsys.readouterr().out
    lut = np.load(out)
    e = {k: _expected(sweeps["grid"], k)[0] for k in (0, 1, 2, 3)}
    for k in (1, 2, 3):
        np.testing.assert_array_equal(lut[f"E_f{k}"], e[k])
    np.testing.assert_array_equal(lut["E"], e[0])
    np.testing.assert_allclose(lut["E_rest"], e[0] - e[1] - e[2] - e[3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(lut["E_f1"] + lut["E_f2"] + lut["E_f3"] + lut["E_rest"], lut["E"], atol=1e-15)
    np.testing.assert_allclose(lut["E_avg_f1"] + lut["E_avg_f2"] + lut["E_avg_f3"] + lut["E_avg_rest"],
                               lut["E_avg"], atol=1e-14)
    paths = _expected(sweeps["grid"], 0)[1]
    rest = lut["E_rest"]
    assert np.all(rest > 0)
    np.testing.assert_allclose(lut["E_rest_stderr"], np.sqrt(rest * (1 - rest) / paths), rtol=1e-12)
    # the default layout: the same orders on its (alpha, mu) grid, which this sweep is not on:
    midpoint = synthetic_sweep(tmp_path / "mid.h5", [("alpha", [0.2, 0.6]), ("theta_i_deg", [
        math.degrees(math.acos((i + 0.5) / 4)) for i in range(4)])], _albedo, orders=(0, 1, 2, 3))
    assert _export(midpoint, tmp_path / "m.npz", "--orders", "f2", "1", "0") == 0
    mid = np.load(tmp_path / "m.npz")
    assert str(mid["tables"]) == "f2, f1, f_inf, rest (f_inf minus f2 + f1)"
    np.testing.assert_allclose(mid["E_f1"] + mid["E_f2"] + mid["E_rest"], mid["E"], atol=1e-15)
    assert "E_f3" not in mid.files


def test_npy_stacks_the_E_tables(sweeps, tmp_path):
    assert _export(sweeps["grid"], tmp_path / "t.npy", "--layout", "cycles", "--orders", "1", "2", "inf") == 0
    assert _export(sweeps["grid"], tmp_path / "t.npz", "--layout", "cycles", "--orders", "1", "2", "inf") == 0
    stack, lut = np.load(tmp_path / "t.npy"), np.load(tmp_path / "t.npz")
    assert stack.shape == (4, 32, 32)
    for k, name in enumerate(("E_f1", "E_f2", "E", "E_rest")):
        np.testing.assert_array_equal(stack[k], lut[name])


C_PROGRAM = r"""
#include <stdio.h>
#include "cycles.h"
int main(void) {
    for (int y = 0; y < VCAVITY_CYCLES_N; ++y)
        for (int x = 0; x < VCAVITY_CYCLES_N; ++x)
            printf("%d %d %.9g %.9g\n", y, x, (double)vcavity_cycles_E_f1[y * VCAVITY_CYCLES_N + x],
                   (double)vcavity_cycles_E_rest[y * VCAVITY_CYCLES_N + x]);
    for (int x = 0; x < VCAVITY_CYCLES_N; ++x)
        printf("avg %d %.9g %.9g %.9g\n", x, (double)vcavity_cycles_E_avg[x], (double)vcavity_cycles_r[x],
               (double)vcavity_cycles_mu[x]);
    return 0;
}
"""


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs a C compiler")
def test_c_header_compiles_and_indexes_like_cycles(sweeps, tmp_path):
    assert _export(sweeps["grid"], tmp_path / "cycles.h", "--layout", "cycles", "--orders", "1", "2", "3", "inf") == 0
    (tmp_path / "dump.c").write_text(C_PROGRAM)
    flags = ["-Wall", "-Wextra", "-pedantic", "-Werror"]
    subprocess.run(["gcc", "-std=c99", *flags, "-o", str(tmp_path / "dump"), str(tmp_path / "dump.c")], check=True,
                   cwd=tmp_path)
    lines = subprocess.run([str(tmp_path / "dump")], check=True, capture_output=True, text=True).stdout.splitlines()
    e = {k: _expected(sweeps["grid"], k)[0] for k in (0, 1, 2, 3)}
    rest = e[0] - e[1] - e[2] - e[3]
    f1 = np.full((32, 32), np.nan)
    got_rest = np.full((32, 32), np.nan)
    for line in lines[:1024]:
        y, x, a, b = line.split()
        f1[int(y), int(x)], got_rest[int(y), int(x)] = float(a), float(b)
    np.testing.assert_allclose(f1, e[1], rtol=2.0 ** -23)  # float: 24-bit mantissa
    np.testing.assert_allclose(got_rest, rest, rtol=2.0 ** -23, atol=1e-12)
    avg = np.array([[float(v) for v in line.split()[2:]] for line in lines[1024:]])
    np.testing.assert_allclose(avg[:, 1], NODES, rtol=2.0 ** -23)
    np.testing.assert_allclose(avg[:, 2], NODES, rtol=2.0 ** -23)
    k = 0.5 + ALPHA
    np.testing.assert_allclose(avg[:, 0], 0.6 + 0.8 * ((k - 1) + np.exp(-k)) / k ** 2, rtol=1e-6)


def _missing_nodes_message():
    """The refusal's list, spelled here from the nodes: r node 5; mu nodes 0 and 31."""
    return (f"missing: 1 r node(s) i = 5 (alpha = {ALPHA[5]:.10g}); 2 mu node(s) i = 0 (theta_i_deg = "
            f"{THETA[0]:.10g}), 31 (theta_i_deg = {THETA[31]:.10g})")


REFUSED = [
    ("partial", "x.npz", ["--layout", "cycles"], "--layout cycles needs alpha = r^2 at r = clamp(i/31, 1e-4, 1)"),
    ("partial", "x.h", ["--layout", "cycles"], None),
    ("mu_only", "x.npz", ["--layout", "cycles"], "; missing: 1 mu node(s) i = 31 (theta_i_deg = 0)"),
    ("grid", "x.txt", ["--layout", "cycles"], "--format albedo-lut --layout cycles writes .npz or .npy or .h"),
    ("grid", "x.npy", [], "--format albedo-lut writes .npz or .h"),
    ("no_f3", "x.npz", ["--layout", "cycles", "--orders", "1", "3", "inf"], "--orders = 1 3 inf: sweep '{src}' "
     "has orders 0 (f_inf), 1, 2, not f3"),
    ("grid", "x.npz", ["--orders", "1", "1"], "--orders = '1 1': lists f1 twice"),
    ("grid", "x.npz", ["--orders", "1", "two"], "--orders = '1 two': accepted are orders 1, 2, ..."),
    ("grid", "x.npz", ["--orders", "1", "--order", "2"], "--orders with --order = '2': give one"),
]


@pytest.mark.parametrize("name, file, options, message", REFUSED, ids=[f"{r[0]}-{r[1]}-{len(r[2])}" for r in REFUSED])
def test_refusals_are_one_line_exit_2_and_write_nothing(sweeps, tmp_path, capsys, name, file, options, message):
    out = tmp_path / file
    assert _export(sweeps[name], out, *options) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].startswith("vcavity: error: "), lines
    assert (message or "--layout cycles needs").format(src=sweeps[name]) in lines[0], lines[0]
    if name == "partial":
        assert lines[0].endswith(_missing_nodes_message()), lines[0]
    assert list(tmp_path.iterdir()) == []


def test_layout_and_orders_belong_to_albedo_lut(sweeps, tmp_path, capsys):
    for flags in (["--layout", "cycles"], ["--orders", "1", "inf"]):
        assert main(["export", str(sweeps["grid"]), str(tmp_path / "x.csv"), "--format", "csv", *flags]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{flags[0]} = " in err and "only --format albedo-lut takes it" in err


def test_a_real_sweep_on_the_runs_files_nodes_exports(tmp_path, capsys):
    """The runs file's [sweep] table with a lossless material of the compiled kernel, 64
    paths a direction: the export equals the sweep at every node, and E_rest x paths is the
    whole number of paths that left after 3 or more bounces."""
    grid = RUNS.read_text().split("[sweep]", 1)[1]
    spec = tmp_path / "real.toml"
    spec.write_text('[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 1.0\neta = 1.0\n'
                    "[incidence]\npaths = 64\n[simulation]\nseed = 3\nmax_order = 2\nsensor_resolution = 3\n"
                    f"[sweep]{grid}")
    sweep = tmp_path / "real.h5"
    # one thread: 1024 tiny directions cost thread start-ups, not paths (8 s here, 60 s on 2)
    assert main(["sweep", str(spec), "-o", str(sweep), "-q", "--threads", "1"]) == 0
    out = tmp_path / "real.npz"
    assert _export(sweep, out, "--layout", "cycles", "--orders", "1", "2", "inf") == 0
    capsys.readouterr()
    lut = np.load(out)
    for name, order in (("E_f1", 1), ("E_f2", 2), ("E", 0)):
        np.testing.assert_array_equal(lut[name], _expected(sweep, order)[0])
    beyond = lut["E_rest"] * 64
    np.testing.assert_allclose(beyond, np.round(beyond), atol=1e-9)
    assert np.all(np.round(beyond) >= 0) and np.any(beyond > 0)


def test_E_avg_stderr_is_the_quadrature_sum_of_the_node_errors(sweeps, tmp_path):
    """``E_avg*_stderr[x] = sqrt(sum_y (w_y 2 mu_y E_stderr[y, x])^2)`` with the composite
    Simpson weights written here (1/3 rule on intervals 0-28, 3/8 rule on 28-31; mu_y = y/31,
    unclamped: 2 mu E vanishes at mu = 0): independent node errors add in quadrature (issue 38
    item 4). Deterministic."""
    out = tmp_path / "s.npz"
    assert _export(sweeps["grid"], out, "--layout", "cycles", "--orders", "1", "inf") == 0
    lut = np.load(out)
    h = 1 / 31
    weights = np.zeros(32)
    for start in range(0, 28, 2):
        weights[start:start + 3] += np.array([1, 4, 1]) * h / 3
    weights[28:] += np.array([1, 3, 3, 1]) * 3 * h / 8
    np.testing.assert_allclose(weights.sum(), 1.0, rtol=1e-14)
    mu = np.arange(32) / 31
    for name in ("", "_f1"):
        node_errors = lut[f"E{name}_stderr"]
        assert node_errors.shape == (32, 32) and np.all(node_errors >= 0) and np.any(node_errors > 0)
        expected = np.sqrt(np.sum(((weights * 2 * mu)[:, None] * node_errors) ** 2, axis=0))
        np.testing.assert_allclose(lut[f"E_avg{name}_stderr"], expected, rtol=1e-12, atol=0)
