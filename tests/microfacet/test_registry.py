"""The registry of distributions (vcavity/microfacet/registry.py): the interface of every
module, names and dispatch indices, parameter parsing, and dispatch from Python and from
jitted code. Deterministic (no false-positive rate)."""

import inspect
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from numba import literally

from vcavity._numba.jit import njit  # caches where vcavity's own code does
from vcavity._numba.jit import CACHE_ENABLED
from vcavity.microfacet import beckmann, gaussian, ggx, phong, student_t, registry
from vcavity.microfacet.common import normal_from_slope_angle
from vcavity.parameters import Number, ParameterError, Roughness

INTERFACE = ("NAME", "DESCRIPTION", "PARAMETERS", "SMITH", "params_from", "lobe_width", "sample", "sample_disk",
             "sample_normal", "D", "pdf", "smith_lambda")


def example_values(name):
    """Canonical values of ``name`` from each parameter's documented example."""
    raw = {spec.keys[0]: spec.example for spec in registry.get(name).PARAMETERS}
    return registry.parse(name, raw)


def test_registered_modules_and_names():
    assert registry.NAMES == ("beckmann", "ggx", "phong", "gaussian", "student_t")
    assert registry.MODULES == (beckmann, ggx, phong, gaussian, student_t)
    assert len(set(registry.NAMES)) == len(registry.NAMES) == len(registry.MODULES)
    assert tuple(m.__name__.rsplit(".", 1)[1] for m in registry.MODULES) == registry.DISTRIBUTION_MODULES


@pytest.mark.parametrize("module", registry.MODULES, ids=registry.NAMES)
def test_every_module_has_the_interface(module):
    for attr in INTERFACE:
        assert hasattr(module, attr), (module.NAME, attr)
    assert isinstance(module.NAME, str) and module.NAME
    assert isinstance(module.DESCRIPTION, str) and module.DESCRIPTION and "\n" not in module.DESCRIPTION
    assert module.PARAMETERS and all(isinstance(spec, (Number, Roughness)) for spec in module.PARAMETERS)
    keys = registry.config_keys(module.NAME)
    assert len(set(keys)) == len(keys)
    assert module.SMITH in ("exact", "approximate", "infinite")


def test_smith_status():
    assert {name: registry.get(name).SMITH for name in registry.NAMES} == {
        "beckmann": "exact", "ggx": "exact", "phong": "exact", "gaussian": "infinite",
        "student_t": "exact"}


@pytest.mark.parametrize("name", registry.NAMES)
def test_get_and_kind_of_round_trip(name):
    module = registry.get(name)
    assert module.NAME == name
    kind = registry.kind_of(name)
    assert registry.MODULES[kind] is module and registry.NAMES[kind] == name


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


@pytest.mark.parametrize("name", registry.NAMES)
def test_params_from_and_lobe_width(name):
    values = example_values(name)
    kind, params = registry.params_from(name, values)
    assert kind == registry.kind_of(name)
    assert params.dtype == np.float64 and params.ndim == 1 and params.flags.c_contiguous
    np.testing.assert_array_equal(params, registry.get(name).params_from(values))
    width = registry.lobe_width(name, values)
    assert isinstance(width, float) and 0.0 < width < math.pi / 2
    assert registry.help_lines()  # --help text renders for every distribution


def test_lobe_widths():
    assert registry.lobe_width("beckmann", {"alpha_x": 0.2, "alpha_y": 0.5}) == 0.2
    assert registry.lobe_width("ggx", {"alpha_x": 0.7, "alpha_y": 0.3}) == 0.3
    assert registry.lobe_width("phong", {"exponent": 6.0}) == pytest.approx(0.5, rel=1e-15)
    assert registry.lobe_width("gaussian", {"sigma": 0.35}) == 0.35


@njit(cache=True)
def _dispatch_in_jitted_code(kind, u1, u2, params):
    """Every jitted operation through the registry, with ``kind`` a compile-time constant."""
    literally(kind)
    t, c, s = registry.sample(kind, u1, u2, params)
    mx, my, mz = registry.sample_normal(kind, u1, u2, params)
    a, b = math.sqrt(1.0 - u1) * c, math.sqrt(1.0 - u1) * s
    disk = registry.sample_disk(kind, a, b, a * a + b * b, params)
    return (t, c, s, mx, my, mz, disk[0], registry.D(kind, mx, my, mz, params), registry.pdf(kind, mx, my, mz, params),
            registry.smith_lambda(kind, 0.6, 0.0, 0.8, params))


@njit(cache=True)
def _dispatch_at_run_time(kind, u1, u2, params):
    """The same with a run-time ``kind`` (a branch over the registered modules)."""
    t, c, s = registry.sample(kind, u1, u2, params)
    mx, my, mz = registry.sample_normal(kind, u1, u2, params)
    a, b = math.sqrt(1.0 - u1) * c, math.sqrt(1.0 - u1) * s
    disk = registry.sample_disk(kind, a, b, a * a + b * b, params)
    return (t, c, s, mx, my, mz, disk[0], registry.D(kind, mx, my, mz, params), registry.pdf(kind, mx, my, mz, params),
            registry.smith_lambda(kind, 0.6, 0.0, 0.8, params))


@pytest.mark.parametrize("name", registry.NAMES)
def test_dispatch_resolves_to_the_module_functions(name):
    module = registry.get(name)
    kind, params = registry.params_from(name, example_values(name))
    u1, u2 = 0.75, 0.3
    t, c, s = module.sample(u1, u2, params)
    m = module.sample_normal(u1, u2, params)
    a, b = math.sqrt(1.0 - u1) * c, math.sqrt(1.0 - u1) * s
    expected = (t, c, s, *m, module.sample_disk(a, b, a * a + b * b, params)[0], module.D(*m, params),
                module.pdf(*m, params), module.smith_lambda(0.6, 0.0, 0.8, params))
    # from Python (any int) and from jitted code (a literal): the module's own function
    from_python = (*registry.sample(kind, u1, u2, params), *registry.sample_normal(kind, u1, u2, params),
                   registry.sample_disk(kind, a, b, a * a + b * b, params)[0], registry.D(kind, *m, params),
                   registry.pdf(kind, *m, params), registry.smith_lambda(kind, 0.6, 0.0, 0.8, params))
    assert from_python == expected
    assert _dispatch_in_jitted_code(kind, u1, u2, params) == pytest.approx(expected, rel=1e-15, abs=0.0)
    assert _dispatch_at_run_time(kind, u1, u2, params) == pytest.approx(expected, rel=1e-15, abs=0.0)


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


@pytest.mark.parametrize("module", registry.MODULES, ids=registry.NAMES)
def test_sample_normal_is_the_module_sample_as_a_normal(module):
    """Every ``sample_normal`` is derived once (``common.normal_sampler``): bit for bit the
    normal of ``sample``, and a function of the module itself for Numba's cache (its file and
    module; no closure cell, which would put a per-process dispatcher id in the cache key)."""
    params = module.params_from(example_values(module.NAME))
    for u1, u2 in ((0.0, 0.0), (0.3, 0.7), (0.75, 0.3), (0.999, 0.5), (1.0 - 2.0**-53, 0.9)):
        assert module.sample_normal(u1, u2, params) == normal_from_slope_angle(*module.sample(u1, u2, params))
    py_func = module.sample_normal.py_func
    assert py_func.__module__ == module.__name__ and py_func.__qualname__ == "sample_normal"
    assert py_func.__closure__ is None and inspect.getfile(py_func) == module.__file__
    assert type(module.sample_normal._cache).__name__ == ("FunctionCache" if CACHE_ENABLED else "NullCache")


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
