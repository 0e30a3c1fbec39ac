"""Paired sweep axes ([sweep.paired.NAME], vcavity/sweep/axes.py, docs/sweeps.md): one axis
whose points set several keys together (a metal's eta and k per wavelength). The spec and
its one-line errors, the shipped gold RGB sweep, and a tiny paired sweep through the CLI:
the file carries what each point set as coordinates along the axis, and a point's counts
are a plain run's with the documented seed.

Cheap: the run is 2 wavelengths x 1 roughness x 2 directions x 20 000 paths of the
beckmann + conductor kernel tests/validation/test_conductor_walk.py compiles. Every
comparison is exact: no statistical false positives.
"""

import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from vcavity import config as config_mod
from vcavity.cli import main
from vcavity.simulate.pipeline import simulate
from vcavity.sweep import spec as sweep_mod

ROOT = Path(__file__).resolve().parents[2]
BASE = ('[material]\ndistribution = "beckmann"\nalpha = 0.4\nfacet = "conductor"\n'
        "[incidence]\npaths = 20_000\n[simulation]\nseed = 17\nsensor_resolution = 9\n")
PAIRED = "[sweep]\ntheta_i_deg = [0, 60]\n[sweep.paired.wavelength]\nlabel_nm = [659.5, 450.9]\n" \
         "eta = [0.14, 1.38]\nk = [3.697, 1.914]\n"


def _parse(text):
    return sweep_mod.parse(tomllib.loads(text))


def test_a_paired_axis_sets_its_keys_point_by_point():
    sweep = _parse(BASE.replace("alpha = 0.4\n", "") + "[sweep]\nalpha = [0.2, 0.5]\n"
                   "[sweep.paired.wavelength]\nlabel_nm = [659.5, 548.6, 450.9]\neta = [0.14, 0.43, 1.38]\n"
                   "k = [3.697, 2.455, 1.914]\n")
    assert [a.name for a in sweep.axes] == ["alpha", "wavelength", "theta_i_deg"]
    assert sweep.point_axes == ("alpha", "wavelength") and len(sweep.points) == 6
    wavelength = sweep.axes[1]
    assert wavelength.values == (659.5, 548.6, 450.9) and wavelength.units == "nm"
    assert [(key, values) for key, values, *_ in wavelength.paired] == [("eta", (0.14, 0.43, 1.38)),
                                                                          ("k", (3.697, 2.455, 1.914))]
    for point in sweep.points:
        i, j = point.index
        assert point.config.material.distribution_params["alpha_x"] == (0.2, 0.5)[i]
        assert point.config.material.facet_params == {"eta": (0.14, 0.43, 1.38)[j], "k": (3.697, 2.455, 1.914)[j]}
    # the same materials as plain runs: the seeds are the points' own, as for any axis
    assert len({p.config.seed for p in sweep.points}) == 6


def test_the_shipped_gold_rgb_sweep_is_johnson_and_christy():
    sweep = sweep_mod.load(ROOT / "runs" / "sweep_gold_rgb.toml")
    axis = next(a for a in sweep.axes if a.name == "wavelength")
    assert axis.values == (659.5, 548.6, 450.9)  # 1.88, 2.26, 2.75 eV
    assert dict((key, values) for key, values, *_ in axis.paired) == {"eta": (0.14, 0.43, 1.38),
                                                                      "k": (3.697, 2.455, 1.914)}
    assert all(p.config.material.facet == "conductor" for p in sweep.points)


BAD = [
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550, 450]\neta = [0.14, 0.43, 1.38]\nk = [3.7, 2.5]\n",
     "sweep.paired.wavelength.k = [3.7, 2.5]: has 2 values, sweep.paired.wavelength.label_nm has 3; the lists "
     "of a paired axis must have the same length"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\neta = [0.14, 0.43]\nkk = [3.7, 2.5]\n",
     "sweep.paired.wavelength.kk = [3.7, 2.5]: not a parameter a paired axis can set; accepted: microsurface, distribution, "),
    ("[sweep.paired.wavelength]\neta = [0.14, 0.43]\nk = [3.7, 2.5]\n",
     "needs exactly one label list (label or label_<units>) naming its points"),
    ("[sweep.paired.wavelength]\nlabel = [1, 2]\nlabel_nm = [650, 550]\neta = [0.14, 0.43]\n",
     "needs exactly one label list"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\n", "sets no parameter"),
    ("[sweep]\neta = [0.2, 0.3]\n[sweep.paired.wavelength]\nlabel_nm = [650, 550]\neta = [0.14, 0.43]\n",
     "sweep.paired.wavelength.eta = [0.14, 0.43]: eta is already swept by sweep.eta"),
    ("[sweep.paired.eta]\nlabel_nm = [650, 550]\nk = [3.7, 2.5]\n", "sweep.paired.eta = "),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\neta = [0.14, 0.43]\nk = [-1, 2.5]\n",
     "sweep.paired.wavelength.k[0] = -1: must be >= 0"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\nkd = [0.5, 0.6]\n",
     "sweep.paired.wavelength.kd = [0.5, 0.6]: not used by facet 'conductor' (it takes: eta, k)"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 650]\neta = [0.14, 0.43]\nk = [3.7, 2.5]\n",
     "sweep.paired.wavelength.label_nm[1] = 650: repeats sweep.paired.wavelength.label_nm[0]"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\nk = [3.7, [2.5]]\n",
     "sweep.paired.wavelength.k[1] = [2.5]: must be a single value"),
    ("[sweep]\npaired = [1, 2]\n", "sweep.paired = [1, 2]: must hold at least one named table"),
    ("[sweep.paired.wavelength]\nlabel_nm = [650, 550]\ntheta_i_deg = [0, 30]\n",
     "sweep.paired.wavelength.theta_i_deg = [0, 30]: not a parameter a paired axis can set"),
]


@pytest.mark.parametrize("table, message", BAD, ids=range(len(BAD)))
def test_bad_paired_axes_are_one_line_errors(table, message):
    with pytest.raises(sweep_mod.SweepError) as info:
        _parse(BASE + table)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_a_bad_paired_sweep_through_the_cli_is_exit_2_and_no_file(tmp_path, capsys):
    spec = tmp_path / "bad.toml"
    spec.write_text(BASE + BAD[0][0])
    assert main(["sweep", str(spec), "-o", str(tmp_path / "out.h5"), "-q"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("vcavity: error: sweep.paired.wavelength.k = ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_a_paired_sweep_runs_and_its_points_are_plain_runs(tmp_path):
    spec = tmp_path / "gold.toml"
    spec.write_text(BASE + PAIRED)
    out = tmp_path / "gold.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q"]) == 0
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert list(ds.wavelength.values) == [659.5, 450.9] and ds.wavelength.attrs["units"] == "nm"
        assert list(ds.eta.values) == [0.14, 1.38] and list(ds.k.values) == [3.697, 1.914]
        assert ds.eta.dims == ("wavelength",) and "eta" in ds.albedo.coords
        counts = ds.counts.sel(wavelength=450.9).values
        seed = int(ds.seed.sel(wavelength=450.9))
        red, blue = (ds.albedo.sel(order=0, wavelength=w).values for w in (659.5, 450.9))
    assert np.all(blue < red)  # gold reflects less blue than red
    plain = config_mod.validate({"material": {"distribution": "beckmann", "alpha": 0.4, "facet": "conductor",
                                              "eta": 1.38, "k": 1.914},
                                 "incidence": {"theta_i_deg": [0, 60], "paths": 20_000},
                                 "simulation": {"seed": seed, "sensor_resolution": 9}})
    assert np.array_equal(simulate(plain)["counts"], counts)
    assert seed == sweep_mod.point_seed(17, plain.material)


def test_sweep_help_documents_paired_axes(capsys):
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = capsys.readouterr().out
    assert "[sweep.paired.wavelength]" in text and "label_nm" in text and "runs/sweep_gold_rgb.toml" in text


def test_the_digest_follows_the_paired_values():
    digest = _parse(BASE + PAIRED).digest
    assert _parse(BASE + PAIRED.replace("1.914", "1.915")).digest != digest  # --resume refuses it
    assert _parse(BASE + PAIRED.replace("label_nm", "label_um")).digest == digest  # units: a name only
