"""The registry of facet models (vcavity/facet/registry.py): registration, unknown names,
parsing, the helpers of the limits, and the interface check of EXAMPLES at import.
Deterministic (no false-positive rate).

What every registered module must satisfy (its interface, its examples through the config
and covering its variants, prepare and the analytic terms, dispatch from Python and from
jitted code, the event's energy) is checked on every module and example in
tests/facet/test_conformance.py."""

import math

import pytest

from vcavity.facet import conductor, interfaced_lambertian, mirror, registry
from vcavity.parameters import ParameterError


def test_registered_modules_and_names():
    # the first three in this order (a new facet model is appended: kinds of the others keep)
    assert registry.NAMES[:3] == ("interfaced_lambertian", "mirror", "conductor")
    assert registry.MODULES[:3] == (interfaced_lambertian, mirror, conductor)
    assert registry.NAMES == tuple(module.NAME for module in registry.MODULES)
    assert len(set(registry.NAMES)) == len(registry.NAMES) == len(registry.MODULES)
    assert tuple(m.__name__.rsplit(".", 1)[1] for m in registry.MODULES) == registry.FACET_MODULES


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


def test_mirror_and_limits_through_the_registry():
    assert registry.body_factor("mirror", {}) == 0.0 and registry.has_specular("mirror", {})
    assert registry.body_factor("interfaced_lambertian", {"kd": 0.0, "eta": 1.5}) == 0.0
    assert not registry.has_specular("interfaced_lambertian", {"kd": 0.4, "eta": 1.0})
    assert registry.body_factor("interfaced_lambertian", {"kd": 0.4, "eta": 1.0}) == pytest.approx(0.4 / math.pi)


@pytest.mark.parametrize("examples, message", [
    (None, "EXAMPLES: a non-empty dict"),
    ({"typical": {"kd": 0.5, "alpha": 0.3}}, "a dict of the module's keys"),
    ({"typical": {"kd": 1.5}}, "must be in"),
    ({"typical": {"kd": 0.5}}, "select no example of the variant"),
])
def test_examples_are_checked_at_import(monkeypatch, examples, message):
    """A module's EXAMPLES is checked as the registry imports it (``_check_examples``, called on
    every module at import): a bad set, or sets that leave a compiled variant untried, is an
    ImportError. Here on a clone of the interfaced Lambertian facet registered for the test."""
    import types

    clone = types.ModuleType("vcavity.facet.clone")
    clone.__dict__.update({k: v for k, v in vars(interfaced_lambertian).items() if not k.startswith("__")})
    clone.NAME = "clone"
    monkeypatch.setattr(registry.REGISTRY, "modules", registry.MODULES + (clone,))
    clone.EXAMPLES = examples
    with pytest.raises(ImportError, match=message):
        registry._check_examples(clone)
    clone.EXAMPLES = dict(interfaced_lambertian.EXAMPLES)
    registry._check_examples(clone)  # a good one passes
