"""Config validation: every bad value gets a one-line ConfigError naming field and value."""

import math

import pytest

from vcavity.config import ConfigError, Material, default_config, load, validate


def _raw(**material):
    base = {"distribution": "beckmann", "alpha": 0.5, "facet": "interfaced_lambertian", "kd": 0.5, "eta": 1.5}
    base.update(material)
    return {"material": {k: v for k, v in base.items() if v is not None}, "incidence": {"theta_i_deg": [10.0]}}


def test_default_is_figure_7b():
    cfg = default_config()
    m = cfg.material
    assert (m.distribution, m.facet) == ("beckmann", "interfaced_lambertian")
    assert m.distribution_params == {"alpha_x": 0.6, "alpha_y": 0.6}
    assert m.facet_params == {"kd": 0.9, "eta": 1.5}
    assert (m.distribution_params["alpha_x"], m.distribution_params["alpha_y"], m.facet_params["kd"],
            m.facet_params["eta"]) == (0.6, 0.6, 0.9, 1.5)
    assert cfg.orders == (0, 1, 2, 3)
    assert len(cfg.incidence) >= 3


def test_degrees_become_radians_and_scalars_broadcast():
    cfg = validate({"material": {"distribution": "ggx", "alpha_x": 0.1, "alpha_y": 0.3, "kd": 1.0},
                    "incidence": {"theta_i_deg": [0, 45], "phi_i_deg": 90, "paths": [10, 20]}})
    assert [d.theta_i for d in cfg.incidence] == [0.0, math.radians(45)]
    assert [d.phi_i for d in cfg.incidence] == [math.radians(90)] * 2
    assert [d.paths for d in cfg.incidence] == [10, 20]
    assert not cfg.material.isotropic


@pytest.mark.parametrize(
    "material, field, value",
    [
        ({"alpha": 0.0}, "material.alpha", "0.0"),
        ({"alpha": -1.0}, "material.alpha", "-1.0"),
        ({"alpha": "rough"}, "material.alpha", "'rough'"),
        ({"alpha": float("nan")}, "material.alpha", "nan"),
        ({"kd": 1.0 + 1e-12}, "material.kd", "1.000000000001"),
        ({"kd": -0.1}, "material.kd", "-0.1"),
        ({"eta": 1.0 - 1e-12}, "material.eta", "0.999999999999"),
        ({"eta": True}, "material.eta", "True"),
        ({"distribution": "cauchy"}, "material.distribution", "'cauchy'"),
        ({"facet": "velvet"}, "material.facet", "'velvet'"),
        ({"roughness": 0.2}, "material.roughness", "0.2"),
        ({"exponent": 20.0}, "material.exponent", "20.0"),
        ({"alpha": 0.3, "alpha_x": 0.2}, "material.alpha_x", "0.2"),
    ],
)
def test_bad_material_values(material, field, value):
    with pytest.raises(ConfigError) as info:
        validate(_raw(**material))
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{field} = {value}:"), message


@pytest.mark.parametrize(
    "incidence, field",
    [
        ({"theta_i_deg": [90.0]}, "incidence.theta_i_deg = 90.0"),
        ({"theta_i_deg": [-1.0]}, "incidence.theta_i_deg = -1.0"),
        ({"theta_i_deg": ["30"]}, "incidence.theta_i_deg = '30'"),
        ({"theta_i_deg": [10.0], "paths": 0}, "incidence.paths = 0"),
        ({"theta_i_deg": [10.0], "paths": 1500.5}, "incidence.paths = 1500.5"),  # 1.5e6 is accepted
        ({"theta_i_deg": [10.0, 20.0], "paths": [1, 2, 3]}, "incidence.paths = [1, 2, 3]"),
        ({"theta_i_deg": [10.0], "psi": 3}, "incidence.psi = 3"),
    ],
)
def test_bad_incidence(incidence, field):
    raw = _raw()
    raw["incidence"] = incidence
    with pytest.raises(ConfigError, match="^" + field.replace("[", r"\[").replace(".", r"\.")):
        validate(raw)


@pytest.mark.parametrize(
    "simulation, field",
    [
        ({"max_order": 0}, "simulation.max_order = 0"),
        ({"max_order": 4, "max_bounces": 3}, "simulation.max_bounces = 3"),
        ({"seed": -1}, "simulation.seed = -1"),
        ({"sensor_resolution": 0}, "simulation.sensor_resolution = 0"),
        ({"track_all_orders": "yes"}, "simulation.track_all_orders = 'yes'"),
        ({"threads": 2}, "simulation.threads = 2"),
        ({"device": "gpu"}, "simulation.device = 'gpu'"),
        ({"device": 1}, "simulation.device = 1"),
    ],
)
def test_bad_simulation(simulation, field):
    raw = _raw()
    raw["simulation"] = simulation
    with pytest.raises(ConfigError, match="^" + field.replace(".", r"\.")):
        validate(raw)


def test_mirror_rejects_il_parameters():
    with pytest.raises(ConfigError, match=r"^material\.kd = 0\.5: not used by facet 'mirror'"):
        validate(_raw(facet="mirror", eta=None))
    with pytest.raises(ConfigError) as info:
        validate(_raw(facet="mirror", eta=None))
    assert str(info.value) == "material.kd = 0.5: not used by facet 'mirror' (it takes: nothing)"


def test_key_of_another_distribution_names_what_this_one_takes():
    with pytest.raises(ConfigError) as info:
        validate(_raw(exponent=20.0))
    assert str(info.value) == ("material.exponent = 20.0: not a parameter of distribution 'beckmann' "
                               "(it takes: alpha, alpha_x, alpha_y)")


def test_unknown_key_lists_the_accepted_keys():
    with pytest.raises(ConfigError) as info:
        validate(_raw(roughness=0.2))
    assert str(info.value) == ("material.roughness = 0.2: unknown key; accepted keys: microsurface, distribution, "
                               "alpha, alpha_x, alpha_y, facet, kd, eta")


def test_kd_is_required_for_interfaced_lambertian():
    # no silent default of 0 (a specular dielectric): a one-line error naming material.kd
    for material in ({"alpha": 0.5}, {"alpha": 0.5, "eta": 1.5}, {"alpha": 0.5, "facet": "interfaced_lambertian"}):
        with pytest.raises(ConfigError) as info:
            validate({"material": material})
        message = str(info.value)
        assert "\n" not in message
        assert message.startswith("material.kd is missing: facet 'interfaced_lambertian' needs kd ("), message
    # eta defaults to 1.5; mirror takes nothing
    assert validate({"material": {"alpha": 0.5, "kd": 0.3}}).material.facet_params == {"kd": 0.3, "eta": 1.5}
    assert validate({"material": {"alpha": 0.5, "facet": "mirror"}}).material.facet_params == {}


def test_missing_roughness_names_the_field():
    with pytest.raises(ConfigError, match=r"^material\.alpha is missing"):
        validate(_raw(alpha=None))
    with pytest.raises(ConfigError, match=r"^material\.sigma is missing"):
        validate(_raw(distribution="gaussian", alpha=None))


def test_unreadable_and_invalid_toml(tmp_path):
    with pytest.raises(ConfigError, match="cannot read it"):
        load(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[material\nalpha = 1\n")
    with pytest.raises(ConfigError, match="invalid TOML") as info:
        load(bad)
    assert "\n" not in str(info.value)


def test_output_path_is_relative_to_the_config(tmp_path):
    (tmp_path / "sub").mkdir()
    path = tmp_path / "sub" / "run.toml"
    path.write_text('[material]\nalpha = 0.2\nkd = 1.0\n[output]\npath = "t.h5"\n')
    assert load(path).output == tmp_path / "sub" / "t.h5"


def test_round_trip_through_to_dict():
    cfg = default_config()
    assert cfg.replace(seed=5).seed == 5
    assert cfg.replace(seed=5).material == cfg.material


def test_the_device_round_trips_and_a_cpu_run_is_what_it_was_before_the_key():
    """``simulation.device``: "cpu" by default; "cuda" survives to_dict, validate and
    replace; a CPU run's dict has no device key, so its checkpoint's and sweep file's
    digests are those of files written before the key existed."""
    from vcavity import config as config_mod
    from vcavity.cli.tracing import add_budget_flags
    from vcavity.kernels import walks

    raw = _raw()
    cpu = validate(raw)
    assert cpu.device == "cpu" and "device" not in cpu.to_dict()["simulation"]
    assert validate({**raw, "simulation": {"device": "cpu"}}).to_dict() == cpu.to_dict()
    cuda = validate({**raw, "simulation": {"device": "cuda"}})
    assert cuda.device == "cuda" and cuda.to_dict()["simulation"]["device"] == "cuda"
    assert cuda.replace(seed=3).device == "cuda" and cpu.replace(device="cuda") == cuda
    assert cuda.replace(device="cpu") == cpu
    as_raw = cuda.to_dict()
    as_raw.pop("source")
    as_raw["output"] = {}
    assert validate(as_raw) == cuda
    # one list of devices: the config's, the walks' and the --device flag's choices
    import argparse

    parser = argparse.ArgumentParser()
    add_budget_flags(parser)
    flag = next(action for action in parser._actions if "--device" in action.option_strings)
    assert tuple(flag.choices) == config_mod.DEVICES == walks.DEVICES


@pytest.mark.parametrize("theta, phi", [(30, 0), (30.0, 45.0), (10, 100), (89.99999999999999, 359.9), (0.1, -45)])
def test_incident_degrees_are_kept_exactly_as_written(theta, phi):
    cfg = validate({"material": {"alpha": 0.5, "kd": 0.5}, "incidence": {"theta_i_deg": [theta], "phi_i_deg": phi}})
    d = cfg.incidence[0]
    assert d.theta_i_deg == theta and d.phi_i_deg == phi  # e.g. 30 stays 30, not degrees(radians(30))
    assert d.theta_i == math.radians(theta) and d.phi_i == math.radians(phi)
    assert cfg.to_dict()["incidence"]["theta_i_deg"] == [theta]
    assert cfg.to_dict()["incidence"]["phi_i_deg"] == [phi]
    assert cfg.replace(seed=3).incidence[0].theta_i_deg == theta
    # math.degrees(math.radians(30)) is 29.999999999999996: the written value is not recomputed
    assert math.degrees(math.radians(30)) != 30
    assert validate({"material": {"alpha": 0.5, "kd": 0.5},
                     "incidence": {"theta_i_deg": [30]}}).incidence[0].theta_i_deg == 30


# (Every registered distribution's and facet model's examples round-trip through
# Material.to_dict / from_dict, with every example of the other kind: the conformance suites,
# tests/microfacet/test_conformance.py and tests/facet/test_conformance.py.)


def test_conductor_defaults_are_gold_and_its_keys_are_its_own():
    m = validate({"material": {"alpha": 0.3, "facet": "conductor"}}).material
    assert m.facet_params == {"eta": 0.43, "k": 2.455}  # gold at 548.6 nm, Johnson & Christy 1972
    with pytest.raises(ConfigError, match=r"^material\.kd = 0\.5: not used by facet 'conductor' \(it takes: eta, k\)$"):
        validate({"material": {"alpha": 0.3, "facet": "conductor", "kd": 0.5}})
    with pytest.raises(ConfigError, match=r"^material\.k = 1\.0: not used by facet 'interfaced_lambertian'"):
        validate({"material": {"alpha": 0.3, "kd": 0.5, "k": 1.0}})
    with pytest.raises(ConfigError, match=r"^material\.k = -1: must be >= 0$"):
        validate({"material": {"alpha": 0.3, "facet": "conductor", "k": -1}})


def test_material_from_dict_validates():
    with pytest.raises(ConfigError, match=r"^material\.alpha_x = -1\.0: must be > 0"):
        Material.from_dict({"distribution": "ggx", "alpha_x": -1.0, "alpha_y": 0.3, "facet": "mirror"})
    with pytest.raises(ConfigError, match=r"^material\.kd is missing"):
        Material.from_dict({"distribution": "ggx", "alpha_x": 0.3, "alpha_y": 0.3, "facet": "interfaced_lambertian"})
