"""The --quick subset of scripts/stress.py, and checks of its exact f1 reference.

Each quick case must keep every invariant of the script (finite non-negative table, exact
books, bounce cap, energy conservation, no degenerate path, f1 within 5 sigma of the exact
single-bounce albedo). The z-tests have a 5.7e-7 false-alarm probability each (fixed seeds,
so a run is deterministic). The reference itself is checked against closed forms that do
not share its code: the flat limit F + (1 - F) a and the crossed-strings view factor.
"""

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from vcavity.config import validate
from vcavity.facet import interfaced_lambertian
from vcavity.facet import registry as facets
from vcavity.facet.fresnel import emergence_probability, fresnel_dielectric, fresnel_transmittance_array
from vcavity.microfacet import registry as distributions

_SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "stress.py"


def _load_stress():
    if "vcavity_stress_script" not in sys.modules:
        spec = importlib.util.spec_from_file_location("vcavity_stress_script", _SCRIPT)
        module = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = module  # dataclasses need the module registered
        spec.loader.exec_module(module)
    return sys.modules["vcavity_stress_script"]


stress = _load_stress()
QUICK = stress.build_cases(quick=True)


@pytest.mark.parametrize("case", QUICK, ids=[f"{c.name} theta={c.theta_deg:g} phi={c.phi_deg:g}" for c in QUICK])
def test_quick_case_keeps_every_invariant(case):
    row = stress.run_case(case)
    assert row.violations == []
    assert row.values["nonfinite"] == 0 and row.values["degenerate"] == 0


def test_quick_grid_covers_the_nasty_corners():
    names = " ".join(c.name for c in QUICK)
    assert {c.theta_deg for c in QUICK} >= {0.0, 45.0, 89.9, 89.99}
    for token in ("tiny", "huge", "aniso 1000:1", "eta=1.000000001", "eta=1000", "mirror", "IL"):
        assert token in names


def test_full_grid_covers_every_axis_of_the_issue():
    cases = stress.build_cases()
    alphas = {c.material.get("alpha") for c in cases}
    assert alphas >= {1e-4, 1e-3, 0.01, 0.1, 1.0, 3.0, 10.0}
    assert {c.theta_deg for c in cases} >= {0.0, 45.0, 80.0, 89.0, 89.9, 89.99}
    assert {c.material.get("eta") for c in cases} >= {1.0, 1 + 1e-9, 1.0001, 1.5, 3.0, 10.0, 1000.0}
    assert {c.material.get("kd") for c in cases} >= {0.0, 1e-6, 0.5, 1.0}
    ratios = {c.material["alpha_x"] / c.material["alpha_y"] for c in cases if "alpha_x" in c.material}
    assert max(ratios) == pytest.approx(1000.0)
    pairs = {(c.material["distribution"], c.material.get("facet", "interfaced_lambertian")) for c in cases}
    assert len(pairs) == len(distributions.NAMES) * len(facets.NAMES)  # all distributions x all facet models (8)
    assert len({(c.name, c.theta_deg, c.phi_deg) for c in cases}) == len(cases)  # no duplicates


def test_main_prints_a_row_per_case_and_exits_zero(capsys):
    assert stress.main(["--quick", "--only", "eta=1e300"]) == 0
    out = capsys.readouterr().out
    assert "eta=1e300 kd=1" in out and "0 invariant violation(s)" in out


def test_main_exits_non_zero_when_an_invariant_breaks(monkeypatch, capsys):
    exact = stress.f1_reference

    def off_by_a_lot(*args, **kwargs):
        f1, err, spec, spec_err = exact(*args, **kwargs)
        return f1 - 0.05, err, spec, spec_err

    monkeypatch.setattr(stress, "f1_reference", off_by_a_lot)
    assert stress.main(["--quick", "--only", "eta=1e300"]) == 1
    assert "FAIL eta=1e300 kd=1" in capsys.readouterr().out


# ----------------------------------------------------------------------------- reference


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 60.0])
@pytest.mark.parametrize("kd, eta", [(0.0, 1.5), (0.5, 1.0), (0.5, 1.5), (1.0, 1.5), (1e-6, 1000.0), (1.0, 1 + 1e-9)])
def test_reference_flat_limit(theta_deg, kd, eta):
    # alpha -> 0: one flat facet, f1 = F + (1 - F) a (physics.md sec. 4, 7); the rest is
    # O(alpha) of light leaving the body within ~alpha of the facet plane
    mat = {"distribution": "beckmann", "alpha": 1e-4, "kd": kd, "eta": eta}
    f1, err, _, _ = stress.f1_reference(mat, theta_deg)
    f = fresnel_dielectric(math.cos(math.radians(theta_deg)), eta)
    assert f1 == pytest.approx(f + (1.0 - f) * emergence_probability(kd, eta), abs=1e-6)
    assert err < 1e-6


def test_reference_mirror_flat_limit_is_one():
    assert stress.f1_reference({"distribution": "ggx", "alpha": 1e-4, "facet": "mirror"}, 40.0)[0] == pytest.approx(1.0, abs=1e-7)


def _mean_cos_theta_m(distribution, alpha):
    """E[m.n] under pdf D(m)(m.n) by scipy.quad on the slope law (physics.md sec. 2)."""
    if distribution == "beckmann":  # tan^2 = alpha^2 x, x ~ Exp(1)
        value, _ = quad(lambda x: math.exp(-x) / math.sqrt(1.0 + alpha * alpha * x), 0.0, math.inf, epsabs=1e-13)
    else:  # ggx: tan^2 = alpha^2 u/(1 - u), u ~ U(0, 1)
        value, _ = quad(lambda u: math.sqrt((1.0 - u) / (1.0 - u + alpha * alpha * u)), 0.0, 1.0, epsabs=1e-13)
    return value


@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.0, 3.0])
def test_reference_crossed_strings_at_normal_incidence(distribution, alpha):
    # eta = 1, theta_i = 0: every facet is fully lit and the cosine-weighted escape from a
    # facet of length 1/cos(theta_m) through the opening of width 2 is the 2-D view factor
    # (L + 2 - L)/(2L) = cos(theta_m) (crossed strings), so f1 = kd E[m.n] (physics.md sec. 9)
    # Also checks the reference's own error estimate (distance to the half-resolution
    # grid), which the script adds to the Monte-Carlo variance: it must cover the error.
    kd = 0.7
    f1, err, _, _ = stress.f1_reference({"distribution": distribution, "alpha": alpha, "kd": kd, "eta": 1.0}, 0.0)
    assert abs(f1 - kd * _mean_cos_theta_m(distribution, alpha)) <= max(err, 1e-6)
    assert err <= 5e-5


def test_clipped_cos_average_matches_dense_numpy_average():
    rng = np.random.default_rng(8)
    psi = (np.arange(200_000) + 0.5) / 200_000 * np.pi
    for _ in range(200):
        a, b, g = rng.uniform(-2, 3), rng.choice([0.0, rng.uniform(0, 4)]), rng.uniform(0, 1)
        dense = np.clip(a - b * np.cos(psi), 0.0, g).mean()
        assert stress.clipped_cos_average(a, b, g) == pytest.approx(dense, abs=1e-9)


@pytest.mark.parametrize("mz, g, eta", [(0.8, 0.7, 1.5), (0.5, 0.3, 1.5), (0.3, 1.0, 1.0), (0.95, 0.2, 3.0), (0.2, 0.05, 1000.0)])
def test_body_escape_matches_plain_numpy_monte_carlo(mz, g, eta):
    # emerging cosine: cosine-weighted proposals accepted with T (physics.md sec. 4);
    # |z| < 4.5 has a 7e-6 false-alarm probability per case (normal tails)
    rng = np.random.default_rng(5)
    mu = np.sqrt(rng.uniform(size=2_000_000))
    mu = mu[rng.uniform(size=mu.size) < fresnel_transmittance_array(mu, eta)]
    psi = rng.uniform(0.0, 2.0 * np.pi, mu.size)
    st = math.sqrt(1.0 - mz * mz)
    oz = mu * mz - np.sqrt(1.0 - mu * mu) * np.cos(psi) * st
    escape = np.minimum(g, np.clip(2.0 * mz * oz / mu, 0.0, 1.0))
    gl_x, gl_w = np.polynomial.legendre.leggauss(16)
    kind, _, data = facets.prepare("interfaced_lambertian", {"kd": 0.5, "eta": eta})
    exact = stress.body_escape(mz, st, g, kind, data, gl_x, gl_w)
    assert abs(exact - escape.mean()) < 4.5 * escape.std() / math.sqrt(escape.size)


def test_grid_helpers_follow_the_registries():
    # a parameter of the new component replaces BASE's, parameters it does not take are dropped
    assert stress._mat() == stress.BASE
    assert stress._mat(eta=3.0) == {**stress.BASE, "eta": 3.0}
    assert stress._mat(facet="mirror") == {"distribution": "beckmann", "alpha": 0.5, "facet": "mirror"}
    assert stress._mat(alpha_x=0.5, alpha_y=0.05) == {"distribution": "beckmann", "facet": "interfaced_lambertian",
                                                      "kd": 0.5, "eta": 1.5, "alpha_x": 0.5, "alpha_y": 0.05}
    assert stress._mat(distribution="phong", exponent=6.0)["exponent"] == 6.0
    assert "alpha" not in stress._mat(distribution="gaussian", sigma=0.35)
    assert stress.DISTS == distributions.NAMES
    for name in distributions.NAMES:
        for width, fixed in ((1e-4, stress._tiny(name)), (0.5, stress.roughness_of_width(name, 0.5))):
            values = validate({"material": {"distribution": name, **fixed, "facet": "mirror"}}).material
            assert distributions.lobe_width(name, values.distribution_params) == pytest.approx(width, rel=1e-5)
    assert stress.roughness_of_width("phong", 0.5) == stress.MODERATE["phong"]
    assert stress.describe(stress._mat(distribution="ggx", alpha=10.0, kd=1.0)) == "ggx a=10 IL kd=1 eta=1.5"
    assert stress.describe(stress._mat(alpha_x=0.5, alpha_y=0.005, facet="mirror")) == "beckmann a_x=0.5 a_y=0.005 mirror"


def test_reemission_and_lossless_facets():
    def material(**kw):
        return validate({"material": {"distribution": "ggx", "alpha": 0.3, **kw}}).material

    assert stress.reemission_probability(material(facet="mirror")) == 0.0
    assert stress.reemission_probability(material(kd=0.0, eta=1.5)) == 0.0
    for kd, eta in ((1.0, 1.5), (1.0, 1e110), (1.0, 1e300), (0.3, 1.0), (0.5, 1.5)):
        assert stress.reemission_probability(material(kd=kd, eta=eta)) == emergence_probability(kd, eta)
        data = interfaced_lambertian.prepare({"kd": kd, "eta": eta})
        assert stress.reemission_probability(material(kd=kd, eta=eta)) == data[1]  # what the facet event uses
    assert stress._lossless(material(facet="mirror")) and stress._lossless(material(kd=1.0, eta=1e300))
    assert not stress._lossless(material(kd=0.999, eta=1.5)) and not stress._lossless(material(kd=0.0, eta=1.5))


def test_grid_needs_no_edit_for_a_new_distribution(monkeypatch):
    # register a new distribution (a clone of GGX under another name) in the Python-level
    # registry only: the grid, its labels and the roughness helpers come from its
    # declarations, with no edit to scripts/stress.py
    import types

    from vcavity.microfacet import ggx, registry

    clone = types.ModuleType("clone")
    clone.__dict__.update({k: v for k, v in vars(ggx).items() if not k.startswith("__")})
    clone.NAME = "clone_t"
    monkeypatch.setattr(registry, "MODULES", registry.MODULES + (clone,))
    monkeypatch.setattr(registry, "NAMES", registry.NAMES + (clone.NAME,))
    monkeypatch.setattr(registry.REGISTRY, "modules", registry.MODULES + (clone,))
    cases = stress.build_cases()
    new = [c for c in cases if c.material["distribution"] == "clone_t"]
    assert {c.material.get("facet", "interfaced_lambertian") for c in new} == set(facets.NAMES)
    assert any("tiny" in c.name for c in new) and any(c.name.startswith("dist clone_t") for c in new)
    for c in new:
        m = validate({"material": c.material}).material  # a complete, valid material
        assert "clone_t" in stress.describe(c.material)
        width = distributions.lobe_width("clone_t", m.distribution_params)
        assert width == pytest.approx(1e-4, rel=1e-5) if "tiny" in c.name else width == pytest.approx(0.5, rel=1e-5)
    assert len({(c.name, c.theta_deg, c.phi_deg) for c in cases}) == len(cases)


def test_grid_needs_no_edit_for_a_new_facet_model(monkeypatch):
    # register a new facet model (a clone of the conductor under another name) in the
    # Python-level registry only: every distribution meets it in the grid, with each of its
    # variants' first example, and the f1 reference's re-emission takes it from its analytic
    # terms, with no edit to scripts/stress.py or scripts/stress_f1.py (the jitted dispatchers
    # know only the modules registered at import, so nothing is simulated here)
    import types

    from vcavity.facet import conductor
    from vcavity.facet import registry as facet_registry

    clone = types.ModuleType("clone")
    clone.__dict__.update({k: v for k, v in vars(conductor).items() if not k.startswith("__")})
    clone.NAME = "clone_metal"
    monkeypatch.setattr(facet_registry, "MODULES", facet_registry.MODULES + (clone,))
    monkeypatch.setattr(facet_registry, "NAMES", facet_registry.NAMES + (clone.NAME,))
    monkeypatch.setattr(facet_registry.REGISTRY, "modules", facet_registry.MODULES + (clone,))
    cases = stress.build_cases()
    new = [c for c in cases if c.material.get("facet") == "clone_metal"]
    assert {c.material["distribution"] for c in new} == set(distributions.NAMES)
    assert all(c.name.startswith("dist ") and "clone_metal" in c.name for c in new)
    m = validate({"material": new[0].material}).material
    assert stress.reemission_probability(m) == 0.0
    assert len({(c.name, c.theta_deg, c.phi_deg) for c in cases}) == len(cases)
