"""The registry of facet models (vcavity/facet/registry.py): the interface of every module,
names and dispatch indices, parsing, prepare / variants, and dispatch from Python and from
jitted code. Deterministic (no false-positive rate)."""

import math

import numpy as np
import pytest
from numba import literally

from vcavity._numba.jit import njit  # caches where vcavity's own code does

from vcavity.facet import conductor, interfaced_lambertian, mirror, registry
from vcavity.facet.common import ABSORBED, SCATTERED
from vcavity.parameters import Number, ParameterError

INTERFACE = ("NAME", "DESCRIPTION", "PARAMETERS", "VARIANTS", "variant", "prepare", "event", "reflectance",
             "transmittance", "has_specular", "body_factor")

# canonical values of every registered facet model, with the variant they select
VALUES = {
    "interfaced_lambertian": [({"kd": 0.5, "eta": 1.5}, "interfaced lambertian"),
                              ({"kd": 0.0, "eta": 1.5}, "specular dielectric"),
                              ({"kd": 0.9, "eta": 1.0}, "lambertian")],
    "mirror": [({}, "mirror")],
    "conductor": [({"eta": 0.43, "k": 2.455}, "conductor")],
}


def test_registered_modules_and_names():
    assert registry.NAMES == ("interfaced_lambertian", "mirror", "conductor")
    assert registry.MODULES == (interfaced_lambertian, mirror, conductor)
    assert len(set(registry.NAMES)) == len(registry.NAMES) == len(registry.MODULES)
    assert tuple(m.__name__.rsplit(".", 1)[1] for m in registry.MODULES) == registry.FACET_MODULES
    assert set(VALUES) == set(registry.NAMES)


@pytest.mark.parametrize("module", registry.MODULES, ids=registry.NAMES)
def test_every_module_has_the_interface(module):
    for attr in INTERFACE:
        assert hasattr(module, attr), (module.NAME, attr)
    assert isinstance(module.NAME, str) and module.NAME
    assert isinstance(module.DESCRIPTION, str) and module.DESCRIPTION and "\n" not in module.DESCRIPTION
    assert all(isinstance(spec, Number) for spec in module.PARAMETERS)
    assert module.VARIANTS and len(set(module.VARIANTS)) == len(module.VARIANTS)
    keys = registry.config_keys(module.NAME)
    assert len(set(keys)) == len(keys) and keys == registry.value_keys(module.NAME)


@pytest.mark.parametrize("name", registry.NAMES)
def test_get_and_kind_of_round_trip(name):
    module = registry.get(name)
    assert module.NAME == name
    kind = registry.kind_of(name)
    assert registry.MODULES[kind] is module and registry.NAMES[kind] == name


def test_unknown_name_raises_key_error_listing_the_registered_ones():
    for bad in ("velvet", "Mirror", ""):
        for function in (registry.get, registry.kind_of):
            with pytest.raises(KeyError) as info:
                function(bad)
            message = str(info.value)
            assert repr(bad) in message
            assert all(name in message for name in registry.NAMES)


def test_parse():
    assert registry.parse("interfaced_lambertian", {"kd": 0.5}) == {"kd": 0.5, "eta": 1.5}
    assert registry.parse("interfaced_lambertian", {"kd": 1, "eta": 2, "alpha": 0.3}) == {"kd": 1.0, "eta": 2.0}
    assert registry.parse("mirror", {"alpha": 0.3}) == {}
    with pytest.raises(ParameterError) as info:
        registry.parse("interfaced_lambertian", {"eta": 1.5})
    assert str(info.value).startswith("material.kd is missing: facet 'interfaced_lambertian' needs kd (")
    with pytest.raises(ParameterError, match=r"^material\.eta = 0\.5: must be >= 1$"):
        registry.parse("interfaced_lambertian", {"kd": 0.5, "eta": 0.5})
    assert registry.help_lines()


@pytest.mark.parametrize("name", registry.NAMES)
def test_prepare_variant_and_body(name):
    module = registry.get(name)
    for values, variant_name in VALUES[name]:
        kind, variant, data = registry.prepare(name, values)
        assert kind == registry.kind_of(name)
        assert isinstance(variant, int) and module.VARIANTS[variant] == variant_name
        assert registry.variant_name(name, values) == variant_name
        assert data.dtype == np.float64 and data.flags.c_contiguous
        np.testing.assert_array_equal(data, module.prepare(values))
        assert registry.has_specular(name, values) is bool(module.has_specular(values))
        factor = registry.body_factor(name, values)
        assert isinstance(factor, float) and factor == module.body_factor(values) and factor >= 0.0
        for c in (0.0, 0.3, 1.0):
            r = registry.reflectance(kind, c, data)
            t = registry.transmittance(kind, c, data)
            assert r == module.reflectance(c, data) and t == module.transmittance(c, data)
            assert 0.0 <= r <= 1.0 and 0.0 <= t <= 1.0
            assert abs(r + t - 1.0) <= 1e-15 or (name in ("mirror", "conductor") and t == 0.0)


def test_mirror_and_limits_through_the_registry():
    assert registry.body_factor("mirror", {}) == 0.0 and registry.has_specular("mirror", {})
    assert registry.body_factor("interfaced_lambertian", {"kd": 0.0, "eta": 1.5}) == 0.0
    assert not registry.has_specular("interfaced_lambertian", {"kd": 0.4, "eta": 1.0})
    assert registry.body_factor("interfaced_lambertian", {"kd": 0.4, "eta": 1.0}) == pytest.approx(0.4 / math.pi)


@njit(cache=True)
def _event_via_registry(kind, variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    literally(kind)
    literally(variant)
    state = np.uint64(seed)
    state, outcome, ox, oy, oz = registry.event(kind, variant, state, dx, dy, dz, cos_in, nx, nz, data)
    return state, outcome, ox, oy, oz, registry.reflectance(kind, cos_in, data), registry.transmittance(kind, cos_in,
                                                                                                        data)


@njit(cache=True)
def _event_at_run_time(kind, variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    """The same with a run-time ``kind`` (a branch over the registered modules)."""
    state = np.uint64(seed)
    state, outcome, ox, oy, oz = registry.event(kind, variant, state, dx, dy, dz, cos_in, nx, nz, data)
    return state, outcome, ox, oy, oz, registry.reflectance(kind, cos_in, data), registry.transmittance(kind, cos_in,
                                                                                                        data)


@njit(cache=True)
def _il_event(variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    state = np.uint64(seed)
    return interfaced_lambertian.event(variant, state, dx, dy, dz, cos_in, nx, nz, data)


@njit(cache=True)
def _mirror_event(variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    state = np.uint64(seed)
    return mirror.event(variant, state, dx, dy, dz, cos_in, nx, nz, data)


@njit(cache=True)
def _conductor_event(variant, seed, dx, dy, dz, cos_in, nx, nz, data):
    state = np.uint64(seed)
    return conductor.event(variant, state, dx, dy, dz, cos_in, nx, nz, data)


@pytest.mark.parametrize("name", registry.NAMES)
def test_jitted_dispatch_is_the_module_event(name):
    direct = {"interfaced_lambertian": _il_event, "mirror": _mirror_event, "conductor": _conductor_event}[name]
    cos_in, nx, nz = 0.6, math.sin(0.4), math.cos(0.4)
    s = math.sqrt(1.0 - cos_in * cos_in)
    d = (-cos_in * nx + s * nz, 0.0, -cos_in * nz - s * nx)
    for values, _ in VALUES[name]:
        kind, variant, data = registry.prepare(name, values)
        for seed in range(20):
            got = _event_via_registry(kind, variant, seed, *d, cos_in, nx, nz, data)
            assert _event_at_run_time(kind, variant, seed, *d, cos_in, nx, nz, data) == got
            assert got[:5] == direct(variant, seed, *d, cos_in, nx, nz, data)
            assert got[1] in (SCATTERED, ABSORBED)
            assert got[5:] == (registry.get(name).reflectance(cos_in, data), registry.get(name).transmittance(cos_in,
                                                                                                              data))
