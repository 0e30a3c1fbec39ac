"""``[material] microsurface``: the Smith walk beside the V-groove walk, end to end
(config, run, table, info, compare, sweep). The walk itself is tested in
tests/kernels/test_smith_walk.py.

The compare verdicts here are statistical: a correct Smith table passes with the
family-wise false-alarm rate 0.01 of ``vcavity compare`` (fixed seed: deterministic); the
mislabelled cases deviate by hundreds of standard errors (GGX 0.5 mirror at 60 deg: f1
albedo 0.70 on the Smith microsurface, 0.82 on V-cavities, at 2e5 paths), so their chance
of passing is nil.
"""

import h5py
import pytest

from tests.compare.test_single_bounce import write_run
from vcavity.cli import main
from vcavity.compare import compare_table
from vcavity.config import ConfigError, Material, validate
from vcavity.io.table import open_table

SMITH_MIRROR = {"microsurface": "smith", "distribution": "ggx", "alpha": 0.5, "facet": "mirror"}
SMITH_IL = {"microsurface": "smith", "distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5}


def test_the_default_is_the_v_cavity_and_is_not_stored():
    """V-cavity materials write exactly what they wrote before the key existed (today's
    readers read them); a Smith material stores the key, and both round-trip."""
    vcavity = validate({"material": {"distribution": "ggx", "alpha": 0.5, "facet": "mirror"}}).material
    smith = validate({"material": SMITH_MIRROR}).material
    assert vcavity.microsurface == "v-cavity" and "microsurface" not in vcavity.to_dict()
    assert smith.to_dict()["microsurface"] == "smith"
    assert Material.from_dict(smith.to_dict()) == smith and Material.from_dict(vcavity.to_dict()) == vcavity


@pytest.mark.parametrize("material, simulation, field, words", [
    (dict(SMITH_MIRROR, microsurface="smiht"), {}, "material.microsurface", "accepted: v-cavity, smith"),
    (dict(SMITH_MIRROR, distribution="gaussian", sigma=0.3, alpha=None), {}, "material.microsurface",
     "diverges"),
    (SMITH_MIRROR, {"estimator": "paper"}, "simulation.estimator", "use 'analog' or 'exact-f1'"),
    (SMITH_MIRROR, {"estimator": "exact"}, "simulation.estimator", None),
])
def test_refusals_are_one_line(material, simulation, field, words):
    material = {k: v for k, v in material.items() if v is not None}
    with pytest.raises(ConfigError) as exc:
        validate({"material": material, "simulation": simulation})
    message = str(exc.value)
    assert "\n" not in message and message.startswith(field)
    if words:
        assert words in message


@pytest.fixture(scope="module")
def smith_tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("smith")
    return {"mirror": write_run(folder / "mirror.h5", SMITH_MIRROR),
            "il": write_run(folder / "il.h5", SMITH_IL)}


@pytest.mark.parametrize("name", ["mirror", "il"])
def test_a_smith_table_passes_against_its_own_f1_model(smith_tables, name, capsys):
    report = compare_table(open_table(smith_tables[name]))
    assert report.exact_model == "smith-hc" and report.model == "smith-hc"
    assert report.passed
    assert main(["compare", str(smith_tables[name])]) == 0
    assert "f1 vs smith-hc model" in capsys.readouterr().out


def test_a_v_cavity_model_on_a_smith_table_is_refused(smith_tables, capsys):
    assert main(["compare", str(smith_tables["mirror"]), "--model", "vcavity"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "smith-hc" in err
    assert main(["compare", str(smith_tables["mirror"]), "--order", "2"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "V-cavities" in err


def test_a_smith_table_labelled_v_cavity_fails(smith_tables, tmp_path, capsys):
    """The reverse mislabel (the key removed, as an old tool or a careless edit would): the
    V-cavity f1 tests see the Smith walk's f1 and fail."""
    path = tmp_path / "relabelled.h5"
    path.write_bytes(smith_tables["mirror"].read_bytes())
    with h5py.File(path, "r+") as h5:
        del h5["material"].attrs["microsurface"]
    assert main(["compare", str(path)]) == 1
    assert "result: FAIL" in capsys.readouterr().out


def test_info_names_the_microsurface(smith_tables, capsys):
    assert main(["info", str(smith_tables["il"])]) == 0
    assert "material: smith microsurface, beckmann, interfaced_lambertian facets" in capsys.readouterr().out


def test_a_sweep_over_the_microsurface(tmp_path):
    """``[sweep] microsurface = [...]`` is an axis like ``distribution``: each point is its
    own walk, and the two f1 albedos differ as the two microsurfaces do (GGX 0.5 mirror at
    70 deg: V-cavity 0.90, Smith 0.80; 5e4 paths give a standard error of 0.002)."""
    spec = tmp_path / "sweep.toml"
    spec.write_text('[material]\ndistribution = "ggx"\nalpha = 0.5\nfacet = "mirror"\n'
                    '[incidence]\ntheta_i_deg = [70]\npaths = 50_000\n'
                    '[sweep]\nmicrosurface = ["v-cavity", "smith"]\n')
    out = tmp_path / "sweep.h5"
    assert main(["sweep", str(spec), "-o", str(out)]) == 0
    with h5py.File(out, "r") as h5:
        names = [v.decode() if isinstance(v, bytes) else str(v) for v in h5["microsurface"][()]]
        assert names == ["v-cavity", "smith"]
        order = list(h5["order"][()])
        f1 = h5["albedo"][()][..., order.index(1)].ravel()  # (microsurface, theta_i)
    assert f1[0] - f1[1] > 0.05, f1
    assert main(["info", str(out)]) == 0


@pytest.mark.parametrize("material, theta_deg", [(SMITH_MIRROR, 60.0), (SMITH_IL, 40.0)])
def test_exact_f1_on_smith_is_the_height_correlated_model(material, theta_deg):
    """exact-f1 on the Smith microsurface: the walk is the analog one with its first-order
    exits counted, not binned (orders >= 2 bit-identical to the analog run), and the f1 row
    is the cell-averaged height-correlated Smith model, which the analog walk's f1 counts
    must follow: chi-square over cells at p > 1e-4 and the albedo z-test at |z| < 3.9
    (false-positive rate about 2e-4 per case, fixed seed). A V-cavity model in its place
    fails both by hundreds of standard errors (f1 albedo 0.82 against 0.70 for the mirror)."""
    import math

    import numpy as np
    from scipy import stats

    from vcavity.analytic.exact_f1 import f1_cell_integrals
    from vcavity.sensor.grid import EqualAreaSensor
    from vcavity.simulate.pipeline import simulate

    raw = {"material": material, "incidence": {"theta_i_deg": [theta_deg], "paths": 400_000},
           "simulation": {"seed": 5, "max_order": 2, "sensor_resolution": 15, "estimator": "exact-f1"}}
    exact = simulate(validate(raw))
    analog = simulate(validate({**raw, "simulation": {**raw["simulation"], "estimator": "analog"}}))
    n = exact["paths"][0]
    assert np.all(exact["counts"][0, 1] == 0) and exact["unbinned_paths"][0] == analog["counts"][0, 1].sum()
    np.testing.assert_array_equal(exact["counts"][0, 2], analog["counts"][0, 2])
    assert exact.attrs["model_error_ratio"] <= 0.1
    t = math.radians(theta_deg)
    incident = np.array([math.sin(t), 0.0, math.cos(t)])
    model, error = f1_cell_integrals(validate(raw).material, incident, EqualAreaSensor(15), 1e-6)
    observed = analog["counts"][0, 1].astype(float)
    expected = n * model
    big = expected >= 10.0
    obs = np.append(observed[big], observed[~big].sum())
    exp = np.append(expected[big], expected[~big].sum())
    if exp[-1] == 0.0:  # every cell is big
        obs, exp = obs[:-1], exp[:-1]
    chi2 = float(np.sum((obs - exp) ** 2 / exp))
    assert big.sum() > 30 and stats.chi2.sf(chi2, obs.size - 1) > 1e-4, f"chi2 {chi2:.1f} on {obs.size - 1} dof"
    p = model.sum()
    assert abs(observed.sum() - n * p) < 3.9 * math.sqrt(n * p * (1 - p))
    # the table's f1 albedo is the model's (folded or not, the albedo is the sum)
    assert exact["albedo"][0, 1] == pytest.approx(p, rel=1e-9)
