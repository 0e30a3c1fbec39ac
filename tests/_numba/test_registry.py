"""The Registry both registries are made of (vcavity/_numba/registry.py), on a package of
two stand-in modules: lookup, parsing and help from the modules' declarations, errors
that name what is accepted, and registrations refused at import. Deterministic."""

import sys
import types

import pytest

from vcavity._numba.registry import Registry
from vcavity.parameters import Number, ParameterError

INTERFACE = ("NAME", "DESCRIPTION", "PARAMETERS")


def _package(monkeypatch, **modules):
    """A package ``standin`` whose modules have the given attributes (only in sys.modules)."""
    package = types.ModuleType("standin")
    package.__path__ = []
    monkeypatch.setitem(sys.modules, "standin", package)
    for name, attrs in modules.items():
        module = types.ModuleType(f"standin.{name}")
        module.__dict__.update(attrs)
        monkeypatch.setitem(sys.modules, f"standin.{name}", module)


def _registry(names=("first", "second")):
    return Registry("standin", names, noun="thing", title="stand-in thing", interface=INTERFACE,
                    owner="standin.registry")


@pytest.fixture
def two(monkeypatch):
    _package(monkeypatch,
             first={"NAME": "alpha", "DESCRIPTION": "the first",
                    "PARAMETERS": (Number("kd", "albedo", lo=0.0, hi=1.0, example=0.5),)},
             second={"NAME": "beta", "DESCRIPTION": "the second", "PARAMETERS": ()})
    return _registry()


def test_lookup_parse_and_help(two):
    assert two.names == ("alpha", "beta") and two.modules == (sys.modules["standin.first"],
                                                              sys.modules["standin.second"])
    assert two.get("beta") is two.modules[1] and two.kind_of("beta") == 1
    assert two.parse("alpha", {"kd": 0.25, "other": 3}) == {"kd": 0.25}
    assert two.parse("beta", {"kd": 0.25}) == {}
    assert two.config_keys("alpha") == two.value_keys("alpha") == ("kd",)
    lines = two.help_lines()
    assert lines[0] == "alpha: the first" and lines[1].startswith("    kd") and lines[2] == "beta: the second"


def test_errors_name_what_is_accepted(two):
    for function in (two.get, two.kind_of, two.config_keys):
        with pytest.raises(KeyError) as info:
            function("gamma")
        assert str(info.value) == "\"unknown stand-in thing 'gamma'; registered: alpha, beta\""
    with pytest.raises(ParameterError, match=r"^material\.kd is missing: thing 'alpha' needs kd"):
        two.parse("alpha", {})
    assert two.check_kind(1, "where") == 1
    with pytest.raises(ValueError, match=r"^standin\.registry\.where: kind = 2: .*registered: alpha, beta"):
        two.check_kind(2, "where")


def test_a_module_lacking_part_of_the_interface_is_refused(monkeypatch):
    _package(monkeypatch, first={"NAME": "alpha", "PARAMETERS": ()})
    with pytest.raises(ImportError, match=r"^thing module standin\.first lacks DESCRIPTION$"):
        _registry(("first",))


def test_a_name_registered_twice_is_refused(monkeypatch):
    module = {"NAME": "alpha", "DESCRIPTION": "d", "PARAMETERS": ()}
    _package(monkeypatch, first=module, second=module)
    with pytest.raises(ImportError, match="names registered twice: alpha, alpha"):
        _registry()


def test_lookups_follow_a_replaced_module_tuple(two, monkeypatch):
    # what a test does to register a module in Python only (tests/test_stress_quick.py)
    extra = types.SimpleNamespace(NAME="gamma", DESCRIPTION="the third", PARAMETERS=())
    monkeypatch.setattr(two, "modules", two.modules + (extra,))
    assert two.get("gamma") is extra and two.kind_of("gamma") == 2 and two.names[-1] == "gamma"
