"""The registry of distributions (vcavity/microfacet/registry.py): registration, unknown names,
parameter parsing, the vectorised path, the interface check of EXAMPLES at import, and the
derived ``sample_normal`` in Numba's cache. Deterministic (no false-positive rate).

What every registered module must satisfy (its interface, its examples through the config,
dispatch from Python and from jitted code, ...) is checked on every module and example in
tests/microfacet/test_conformance.py."""

import os
import subprocess
import sys

import numpy as np
import pytest

from vcavity._numba.jit import CACHE_ENABLED
from vcavity.microfacet import beckmann, gaussian, ggx, phong, student_t, registry
from vcavity.parameters import ParameterError


def test_registered_modules_and_names():
    # the first five in this order (a new distribution is appended: kinds of the others keep)
    assert registry.NAMES[:5] == ("beckmann", "ggx", "phong", "gaussian", "student_t")
    assert registry.MODULES[:5] == (beckmann, ggx, phong, gaussian, student_t)
    assert registry.NAMES == tuple(module.NAME for module in registry.MODULES)
    assert len(set(registry.NAMES)) == len(registry.NAMES) == len(registry.MODULES)
    assert tuple(m.__name__.rsplit(".", 1)[1] for m in registry.MODULES) == registry.DISTRIBUTION_MODULES


def test_unknown_name_raises_key_error_listing_the_registered_ones():
    for bad in ("cauchy", "Beckmann", ""):
        for function in (registry.get, registry.kind_of):
            with pytest.raises(KeyError) as info:
                function(bad)
            message = str(info.value)
            assert repr(bad) in message
            assert all(name in message for name in registry.NAMES)
    with pytest.raises(KeyError):
        registry.params_from("cauchy", {"alpha_x": 0.5, "alpha_y": 0.5})


def test_parse_canonical_values_and_isotropy():
    assert registry.parse("ggx", {"alpha": 0.3}) == {"alpha_x": 0.3, "alpha_y": 0.3}
    assert registry.parse("beckmann", {"alpha_x": 0.1, "alpha_y": 0.4, "kd": 0.5}) == {"alpha_x": 0.1, "alpha_y": 0.4}
    assert registry.parse("phong", {"exponent": 20}) == {"exponent": 20.0}
    assert registry.parse("gaussian", {"sigma": 0.35}) == {"sigma": 0.35}
    assert registry.value_keys("ggx") == ("alpha_x", "alpha_y")
    assert registry.config_keys("ggx") == ("alpha", "alpha_x", "alpha_y")
    assert registry.is_isotropic("ggx", {"alpha_x": 0.3, "alpha_y": 0.3})
    assert not registry.is_isotropic("ggx", {"alpha_x": 0.3, "alpha_y": 0.4})
    assert registry.is_isotropic("phong", {"exponent": 2.0})
    with pytest.raises(ParameterError, match=r"^material\.sigma is missing"):
        registry.parse("gaussian", {"alpha": 0.3})
    with pytest.raises(ParameterError, match=r"^material\.exponent = -1\.0: must be >= 0$"):
        registry.parse("phong", {"exponent": -1.0})


def test_lobe_widths():
    assert registry.lobe_width("beckmann", {"alpha_x": 0.2, "alpha_y": 0.5}) == 0.2
    assert registry.lobe_width("ggx", {"alpha_x": 0.7, "alpha_y": 0.3}) == 0.3
    assert registry.lobe_width("phong", {"exponent": 6.0}) == pytest.approx(0.5, rel=1e-15)
    assert registry.lobe_width("gaussian", {"sigma": 0.35}) == 0.35


def test_vectorised_path():
    kind, params = registry.params_from("ggx", {"alpha_x": 0.3, "alpha_y": 0.6})
    rng = np.random.default_rng(1)
    m = registry.sample_normals(kind, rng.random(50), rng.random(50), params)
    assert m.shape == (50, 3)
    for op, scalar in (("D", ggx.D), ("pdf", ggx.pdf), ("smith_lambda", ggx.smith_lambda)):
        values = registry.evaluate(op, kind, m, params)
        assert values.shape == (50,)
        np.testing.assert_array_equal(values, [scalar(*row, params) for row in m])
    # a flat list of three floats is one row
    assert registry.evaluate("D", kind, [0.0, 0.0, 1.0], params).shape == (1,)
    with pytest.raises(ValueError, match="op = 'G1'"):
        registry.evaluate("G1", kind, m, params)
    # kinds come from kind_of / params_from; anything else is refused before the jitted loop
    for bad in (len(registry.NAMES), -1, True, 1.0):
        with pytest.raises(ValueError, match="kind"):
            registry.evaluate("D", bad, m, params)
        with pytest.raises(ValueError, match="kind"):
            registry.sample_normals(bad, [0.5], [0.5], params)


@pytest.mark.skipif(not CACHE_ENABLED, reason="no writable Numba cache here")
def test_a_second_process_loads_the_derived_sample_normal_from_the_cache(tmp_path):
    script = ("from vcavity.microfacet import ggx\n"
              "f = ggx.sample_normal\n"
              "print(f(0.3, 0.7, ggx.params_from({'alpha_x': 0.3, 'alpha_y': 0.5})))\n"
              "print(sum(f.stats.cache_hits.values()), sum(f.stats.cache_misses.values()))\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
            for _ in range(2)]
    for run in runs:
        assert run.returncode == 0, run.stderr
    first, second = (run.stdout.splitlines() for run in runs)
    assert first[0] == second[0]
    assert first[1] == "0 1" and second[1] == "1 0"  # compiled once, then loaded


@pytest.mark.parametrize("examples, message", [
    (None, "EXAMPLES: a non-empty dict"),
    ({}, "EXAMPLES: a non-empty dict"),
    ({"Typical": {"alpha": 0.3}}, "names are lower-case identifiers"),
    ({"typical": {"alpah": 0.3}}, "a dict of the module's keys"),
    ({"typical": {"alpha": -0.3}}, "must be > 0"),
    ({"typical": {"alpha_x": 0.3}}, "alpha_y is missing"),
])
def test_examples_are_checked_at_import(monkeypatch, examples, message):
    """A module's EXAMPLES is checked as the registry imports it (``_check_examples``, called
    on every module at import): a bad set is an ImportError naming the module and the set.
    Here on a clone of GGX registered for the test."""
    import types

    clone = types.ModuleType("vcavity.microfacet.clone")
    clone.__dict__.update({k: v for k, v in vars(ggx).items() if not k.startswith("__")})
    clone.NAME = "clone"
    monkeypatch.setattr(registry.REGISTRY, "modules", registry.MODULES + (clone,))
    clone.EXAMPLES = examples
    with pytest.raises(ImportError, match=message):
        registry._check_examples(clone)
    clone.EXAMPLES = {"typical": {"alpha": 0.3}}
    registry._check_examples(clone)  # a good one passes
