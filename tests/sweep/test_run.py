"""Sweeps (vcavity sweep): the file opens in xarray as a labelled grid, a point's counts are
those of a plain run with the point's documented seed, points do not depend on the rest
of the grid, an interrupted sweep resumes to the same file, and bad sweeps are refused
before anything runs.

Cheap: tiny grids (2 x 2 points, 2 directions, 20 000 paths, 9 x 9 cells) of the
beckmann + interfaced_lambertian (kd > 0, eta != 1) kernel the suite already compiles.
Every comparison is of integer counts, bit for bit: no statistical false positives.
"""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
import xarray as xr

from vcavity import config as config_mod
from vcavity.sweep import spec as sweep_mod
from vcavity.sweep import run as sweep_run
from vcavity.cli import main
from vcavity.simulate.pipeline import simulate

BASE = ('[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 0.9\n'
        "[incidence]\npaths = 20_000\n[simulation]\nseed = 17\nsensor_resolution = 9\n")
GRID = "[sweep]\nalpha = [0.3, 0.6]\neta = [1.3, 1.5]\ntheta_i_deg = [0, 60]\n"


def _write(folder, name, text):
    path = folder / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """A 2 x 2 sweep run through the CLI: (folder, sweep file, output)."""
    folder = tmp_path_factory.mktemp("sweep")
    spec = _write(folder, "grid.toml", BASE + GRID)
    out = folder / "grid.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q"]) == 0
    return folder, spec, out


def _seed(sweep_seed, material):
    """The seed recipe of docs/sweeps.md, written out here independently of vcavity.sweep.spec."""
    text = json.dumps({"seed": sweep_seed, "material": material}, sort_keys=True)
    return int.from_bytes(hashlib.sha256(("vcavity-sweep-point-v1\n" + text).encode()).digest()[:8], "little")


def _same_file(a, b):
    """Every dataset and attribute equal, except timings and the creation date."""
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        names, others = set(), set()
        fa.visit(names.add)
        fb.visit(others.add)
        assert names == others
        for name in names - {"compute_time_s"}:
            if isinstance(fa[name], h5py.Dataset):
                x, y = fa[name][()], fb[name][()]
                assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name
        for key in set(fa.attrs) - {"created_utc"}:
            x, y = fa.attrs[key], fb.attrs[key]
            assert x == y or (x != x and y != y), key


def test_xarray_reads_a_labelled_grid(swept):
    _, _, out = swept
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.brdf.dims == ("alpha", "eta", "theta_i_deg", "order", "cell")
        assert ds.counts.dims == ds.brdf.dims and ds.albedo.dims == ("alpha", "eta", "theta_i_deg", "order")
        assert ds.paths.dims == ("alpha", "eta", "theta_i_deg") and ds.seed.dims == ("alpha", "eta")
        assert ds.alpha.values.tolist() == [0.3, 0.6] and ds.eta.values.tolist() == [1.3, 1.5]
        assert ds.theta_i_deg.values.tolist() == [0.0, 60.0] and ds.order.values.tolist() == [0, 1, 2, 3]
        assert ds.theta_i_deg.attrs["units"] == "degree" and ds.eta.attrs["units"] == "1"
        np.testing.assert_array_equal(ds.theta_i.values, np.radians([0.0, 60.0]))
        assert float(ds.phi_i_deg) == 0.0 and ds.brdf.attrs["units"] == "1/sr"
        assert {"theta_o", "phi_o", "theta_i"} <= set(ds.brdf.coords)
        albedo = ds.albedo.sel(alpha=0.3, eta=1.5, order=0)
        assert albedo.dims == ("theta_i_deg",)
        counts = ds.counts.sel(alpha=0.3, eta=1.5, order=0).values
        paths = ds.paths.sel(alpha=0.3, eta=1.5).values
        assert paths.tolist() == [20_000, 20_000]
        np.testing.assert_array_equal(albedo.values, counts.sum(axis=-1) / paths)  # analog: exits / paths
        assert ds.done.values.tolist() == [[1, 1], [1, 1]]


def test_a_point_is_a_plain_run_with_the_documented_seed(swept):
    _, _, out = swept
    material = {"distribution": "beckmann", "alpha_x": 0.6, "alpha_y": 0.6, "facet": "interfaced_lambertian",
                "kd": 0.9, "eta": 1.3}
    seed = _seed(17, material)
    cfg = config_mod.validate({"material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.3},
                               "incidence": {"theta_i_deg": [0, 60], "paths": 20_000},
                               "simulation": {"seed": seed, "sensor_resolution": 9}})
    alone = simulate(cfg, threads=1)
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert int(ds.seed.sel(alpha=0.6, eta=1.3)) == seed
        np.testing.assert_array_equal(ds.counts.sel(alpha=0.6, eta=1.3).values, alone["counts"])
        np.testing.assert_array_equal(ds.brdf.sel(alpha=0.6, eta=1.3).values, alone["brdf"])
        seeds = ds.seed.values.ravel().tolist()
        assert len(set(seeds)) == len(seeds)  # every parameter enters the seed


def test_other_points_keep_their_counts_when_values_are_added_or_reordered(swept):
    folder, _, out = swept
    spec = _write(folder, "grown.toml", BASE + "[sweep]\nalpha = [0.45, 0.6, 0.3]\neta = [1.5, 1.3]\n"
                  "theta_i_deg = [60, 30, 0]\n")
    grown = folder / "grown.h5"
    assert main(["sweep", str(spec), "-o", str(grown), "-q", "--threads", "1", "--chunk-blocks", "2"]) == 0
    with xr.open_dataset(out, engine="h5netcdf") as a, xr.open_dataset(grown, engine="h5netcdf") as b:
        common = dict(alpha=[0.3, 0.6], eta=[1.3, 1.5], theta_i_deg=[0.0, 60.0])
        np.testing.assert_array_equal(a.counts.sel(**common).values, b.counts.sel(**common).values)
        np.testing.assert_array_equal(a.seed.values, b.seed.sel(alpha=[0.3, 0.6], eta=[1.3, 1.5]).values)


def test_an_interrupted_sweep_resumes_to_the_same_file(swept, capsys):
    folder, spec, out = swept
    partial = folder / "partial.h5"

    def stop(point, data):
        raise KeyboardInterrupt  # as Ctrl-C after the first point's write

    sweep = sweep_mod.load(spec)
    _, data, _ = sweep_run.plan_output(sweep, str(partial), str(spec))
    with pytest.raises(KeyboardInterrupt):
        sweep_run.run(sweep, partial, data, on_point=stop)
    with h5py.File(partial, "r") as h5:
        assert h5["done"][()].tolist() == [[1, 0], [0, 0]]
        assert np.isnan(h5["brdf"][1, 1]).all() and not np.isnan(h5["brdf"][0, 0]).any()
    capsys.readouterr()
    assert main(["info", str(partial)]) == 0
    info = capsys.readouterr().out
    assert "points: 1 of 4 done" in info and "pending" in info and "axis alpha: 0.3, 0.6" in info
    copy = folder / "partial-copy.h5"
    copy.write_bytes(partial.read_bytes())
    assert main(["sweep", str(spec), "-o", str(partial), "-q", "--resume"]) == 0
    _same_file(out, partial)
    traced = []  # resuming in-process: only the three points not done are traced
    _, data, _ = sweep_run.plan_output(sweep, str(copy), str(spec), resume=True)
    sweep_run.run(sweep, copy, data, on_progress=lambda paths, error: traced.append(paths))
    assert sum(traced) == 3 * 2 * 20_000
    _same_file(out, copy)


def test_info_on_a_sweep_compiles_nothing(swept):
    _, _, out = swept
    code = ("import sys\nfrom vcavity.cli import main\nassert main(['info', sys.argv[1]]) == 0\n"
            "assert 'numba' not in sys.modules, 'info imported numba'\n")
    proc = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "points: 4 of 4 done" in proc.stdout and "axis theta_i_deg (degree), incident direction: 0, 60" \
        in proc.stdout


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_resume_refuses_another_sweep_and_an_existing_output_needs_a_flag(swept, capsys):
    folder, spec, out = swept
    before = _sha(out)
    other = _write(folder, "other.toml", BASE.replace("seed = 17", "seed = 18") + GRID)
    capsys.readouterr()
    assert main(["sweep", str(other), "-o", str(out), "--resume"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds another sweep" in err and "--resume" in err
    assert main(["sweep", str(spec), "-o", str(out)]) == 2
    assert "exists; pass --resume" in capsys.readouterr().err
    assert _sha(out) == before


BAD = [  # (what the [sweep] table or base says, the message's start)
    ("[sweep]\nroughness = [0.1]\n", "sweep.roughness = [0.1]: not a sweep axis; accepted: microsurface, distribution, alpha"),
    ("[sweep]\nalpha = []\n", "sweep.alpha = []: must be a non-empty list"),
    ("[sweep]\nalpha = 0.3\n", "sweep.alpha = 0.3: must be a non-empty list"),
    ("[sweep]\nalpha = [0.3, 0.5, -1]\n", "sweep.alpha[2] = -1: must be > 0"),
    ("[sweep]\nalpha = [0.3, 'rough']\n", "sweep.alpha[1] = 'rough': must be a number"),
    ("[sweep]\nalpha = [0.3]\ngamma = [2.0, 3.0]\n", "sweep.gamma = [2.0, 3.0]: not a parameter of distribution "
     "'beckmann'"),
    ("[sweep]\nalpha = [0.3]\nkd = [0.2, 1.2]\n", "sweep.kd[1] = 1.2: must be in [0, 1]"),
    ("[sweep]\nalpha = [0.3]\ndistribution = ['ggx', 'phong']\n", "sweep.alpha = [0.3]: not a parameter of "
     "distribution 'phong' (sweep.distribution[1])"),
    ("[sweep]\ndistribution = ['ggx', 'fractal']\nalpha = [0.3]\n", "sweep.distribution[1] = 'fractal': accepted:"),
    ("[sweep]\nalpha = [0.3, 0.5, 0.30]\n", "sweep.alpha[2] = 0.3: repeats sweep.alpha[0]"),
    ("[sweep]\nalpha = [0.3]\ntheta_i_deg = [0, 95]\n", "sweep.theta_i_deg[1] = 95: must be in [0, 90)"),
    ("[sweep]\nalpha = [0.3]\nphi_i_deg = [0, 1e300]\n", "sweep.phi_i_deg[1] = 1e+300: must be in [-360, 360]"),
    ("[sweep]\nalpha = [0.3]\nalpha_x = [0.1]\n", "sweep.alpha_x = [0.1]: give either alpha"),
    ("[sweep]\nalpha = [0.3, [0.1]]\n", "sweep.alpha[1] = [0.1]: must be a single value"),
    ("[sweep]\nalpha = [0.3, 0.4]\nkd = [0.5, 0.6]\neta = [1.1, 1.2]\ntheta_i_deg = "
     + str(list(range(90))) + "\nphi_i_deg = " + str(list(range(150))) + "\n", "sweep = '2 x 2 x 2 x 90 x 150 grid'"),
    ("", "sweep is missing: a sweep file needs a [sweep] table"),
]


@pytest.mark.parametrize("table, message", BAD, ids=[m.split(":")[0] for _, m in BAD])
def test_a_bad_sweep_is_one_line_exit_2_and_no_file(tmp_path, capsys, table, message):
    spec = _write(tmp_path, "bad.toml", BASE + table)
    out = tmp_path / "out.h5"
    assert main(["sweep", str(spec), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcavity: error: " + message) and err.count("\n") == 1, err
    assert sorted(os.listdir(tmp_path)) == ["bad.toml"]


@pytest.mark.parametrize("base, message", [
    (BASE.replace("kd = 0.9", 'kd = 0.9\ncolour = "red"'), "material.colour = 'red': unknown key"),
    (BASE.replace("paths = 20_000", "paths = [20_000, 30_000]"), "incidence.paths = [20000, 30000]: a sweep takes "
     "one value here"),
    (BASE.replace("seed = 17", "seed = -1"), "simulation.seed = -1: must be an integer >= 0"),
    (BASE.replace("paths = 20_000", "paths = 20_000\ncolour = 1"), "incidence.colour = 1: unknown key"),
    (BASE.replace('facet = "interfaced_lambertian"\nkd = 0.9', 'facet = "mirror"'), "sweep.eta = [1.3, 1.5]: not "
     "used by facet 'mirror' (it takes: nothing)"),
])
def test_a_bad_base_names_its_field(tmp_path, capsys, base, message):
    spec = _write(tmp_path, "bad.toml", base + GRID)
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out.h5")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcavity: error: " + message) and err.count("\n") == 1, err
    assert sorted(os.listdir(tmp_path)) == ["bad.toml"]


def test_incident_angles_of_the_base_are_the_theta_axis():
    raw = {"material": {"kd": 0.9, "eta": 1.5}, "incidence": {"theta_i_deg": [30, 0]},
           "sweep": {"alpha": [0.3, 0.5]}}
    sweep = sweep_mod.parse(raw)
    assert [(a.name, a.values) for a in sweep.axes] == [("alpha", (0.3, 0.5)), ("theta_i_deg", (30, 0))]
    assert sweep.scalars == {"phi_i_deg": 0.0} and len(sweep.points) == 2 and sweep.n_directions == 2
    raw["incidence"]["theta_i_deg"] = [30, 0, 30.0]
    with pytest.raises(sweep_mod.SweepError, match=r"^incidence.theta_i_deg\[2\] = 30.0: repeats "
                       r"incidence.theta_i_deg\[0\]"):
        sweep_mod.parse(raw)


@pytest.mark.slow
def test_sigkill_and_sigint_mid_sweep_then_resume_give_the_same_file(tmp_path):
    """Real processes: SIGINT (own process group, so it is not ignored) exits 130 with one
    line; SIGKILL loses at most the running point; resuming gives the uninterrupted file."""
    grid = "[sweep]\nalpha = [0.2, 0.3, 0.4, 0.5, 0.6, 0.7]\neta = [1.3, 1.5]\ntheta_i_deg = [0, 60]\n"
    spec = _write(tmp_path, "long.toml", BASE.replace("paths = 20_000", "paths = 1_000_000") + grid)
    full, cut = tmp_path / "full.h5", tmp_path / "cut.h5"
    cli = [sys.executable, "-m", "vcavity.cli", "sweep", str(spec), "-q"]
    subprocess.run(cli + ["-o", str(full)], check=True, capture_output=True)

    def done():
        try:
            with h5py.File(cut, "r") as h5:
                return int(h5["done"][()].sum())
        except OSError:
            return 0

    for sig, resume in ((signal.SIGINT, False), (signal.SIGKILL, True)):
        start = done()
        proc = subprocess.Popen(cli + ["-o", str(cut)] + (["--resume"] if resume else []), start_new_session=True,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 120
        while done() < start + 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        proc.send_signal(sig)
        err = proc.communicate(timeout=120)[1]
        if sig == signal.SIGINT:
            assert proc.returncode == 130 and err.strip().splitlines()[-1].startswith("vcavity: interrupted; ")
            assert "Traceback" not in err
        assert 0 < done() < 12
    subprocess.run(cli + ["-o", str(cut), "--resume"], check=True, capture_output=True)
    _same_file(full, cut)
    assert sorted(os.listdir(tmp_path)) == ["cut.h5", "full.h5", "long.toml"]


@pytest.mark.slow
def test_dask_sweep_equals_local_sweep(swept):
    pytest.importorskip("distributed")
    folder, spec, out = swept
    remote = folder / "dask.h5"
    assert main(["sweep", str(spec), "-o", str(remote), "-q", "--dask", "local:2", "--chunk-blocks", "2"]) == 0
    _same_file(out, remote)
