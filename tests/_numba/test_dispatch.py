"""The registries' dispatch (vcavity/_numba/dispatch.py) on stand-in modules: a constant kind
compiles its own module's function only, a run-time kind the chain over all of them, an
optional function falls back to ``missing``, and Python calls check the kind; with ``direct``
the module's own function (kind first) is the call; and ``apart``:
constants stay constants inside the function compiled apart, which has NumPy's error model.
Deterministic."""

import math
import types

import numba
import pytest

from vcavity._numba.dispatch import apart, dispatcher


def _module(name, **functions):
    module = types.ModuleType(f"standin.{name}")
    module.NAME = name
    module.__dict__.update(functions)
    return module


@numba.njit
def _twice(x):
    return 2.0 * x


@numba.njit
def _plus_one(x):
    return x + 1.0


@numba.njit
def _untypable(x):
    return x.no_such_attribute  # a float has none: typing this fails


def test_a_constant_kind_compiles_only_its_own_module():
    """Numba types an overload with non-literal arguments first by default: the run-time chain,
    which typed and compiled every registered module's function into each kernel variant
    (docs/performance.md, "Compile time: literal kinds first"). The other module's function
    must stay uncompiled, and an untypable one must not matter."""

    @numba.njit
    def other(x):
        return x - 1.0

    op = dispatcher((_module("good", op=_twice), _module("other", op=other)), "op", ("x",), "standin.registry")
    strict = dispatcher((_module("good", op=_twice), _module("bad", op=_untypable)), "op", ("x",), "standin.registry")

    @numba.njit
    def constant_kind(x):
        return op(0, x) + strict(0, x)

    assert constant_kind(1.5) == 6.0
    assert other.signatures == []  # never typed, so never compiled


@numba.njit
def _direct_twice(kind, x):
    return 2.0 * x + kind  # the kind it is called with: its own position in the registry


@numba.njit
def _direct_plus_one(kind, x):
    return x + 1.0 + kind


def test_direct_dispatch_runs_the_module_s_own_code_with_its_kind():
    """``direct``: each module's function takes the kind first; a constant kind's call is that
    function itself (no wrapper), the other module's stays uncompiled; a run-time kind and
    Python calls pass the kind on too."""

    @numba.njit
    def other(kind, x):
        return x - 1.0

    op = dispatcher((_module("good", op=_direct_twice), _module("other", op=other)), "op", ("x",),
                    "standin.registry", direct=True)

    @numba.njit
    def constant_kind(x):
        return op(0, x)

    assert constant_kind(1.5) == 3.0
    assert other.signatures == []  # never typed, so never compiled
    both = dispatcher((_module("first", op=_direct_twice), _module("second", op=_direct_plus_one)), "op", ("x",),
                      "standin.registry", direct=True)

    @numba.njit
    def run_time_kind(kind, x):
        return both(kind, x)

    @numba.njit
    def second(x):
        return both(1, x)

    assert second(1.5) == 3.5  # the second module's own code, called with its kind
    assert [run_time_kind(kind, 1.5) for kind in (0, 1)] == [3.0, 3.5]
    assert [both(kind, 1.5) for kind in (0, 1)] == [3.0, 3.5]  # from Python


def test_a_run_time_kind_takes_the_chain_over_every_module():
    op = dispatcher((_module("first", op=_twice), _module("second", op=_plus_one)), "op", ("x",), "standin.registry")

    @numba.njit
    def run_time_kind(kind, x):
        return op(kind, x)

    assert [run_time_kind(kind, 1.5) for kind in (0, 1)] == [3.0, 2.5]
    assert [op(kind, 1.5) for kind in (0, 1)] == [3.0, 2.5]  # from Python


def test_an_optional_function_falls_back_to_missing_for_constant_and_run_time_kinds():
    op = dispatcher((_module("has", op=_twice), _module("lacks")), "op", ("x",), "standin.registry",
                    missing="math.nan")

    @numba.njit
    def constant_kind(x):
        return op(1, x)

    @numba.njit
    def run_time_kind(kind, x):
        return op(kind, x)

    assert math.isnan(constant_kind(1.5))
    assert run_time_kind(0, 1.5) == 3.0 and math.isnan(run_time_kind(1, 1.5))


@pytest.mark.parametrize("kind", [2, -1, True, 0.5])
def test_python_calls_refuse_a_kind_outside_the_registry(kind):
    op = dispatcher((_module("first", op=_twice), _module("second", op=_plus_one)), "op", ("x",), "standin.registry")
    with pytest.raises(ValueError, match=r"standin\.registry\.op: kind = .*"):
        op(kind, 1.0)


def test_apart_keeps_a_constant_kind_constant():
    """The kernels' walks are compiled apart with their kinds as closure constants; inside, the
    registries' dispatch must still see constants. Typed with a run-time kind (Numba's
    default, non-literal first) it would compile the chain, the other module's function with it."""

    @numba.njit
    def other(x):
        return x - 1.0

    op = dispatcher((_module("good", op=_twice), _module("other", op=other)), "op", ("x",), "standin.registry")

    @numba.njit(inline="always")
    def walk(x, kind):
        return op(kind, x) + 1.0

    walk_apart = apart(walk, "standin.walks")
    KIND = 0

    @numba.njit
    def caller(x):
        return walk_apart(x, KIND)

    assert caller(1.5) == 4.0
    assert other.signatures == []  # never typed, so never compiled


def test_apart_divides_with_numpy_s_error_model():
    """As inside Numba's parallel loops, where the walks were inlined before: 1/0 is inf, not a
    raise (Python's error model would test every division)."""

    @numba.njit(inline="always")
    def ratio(x, y):
        return x / y

    ratio_apart = apart(ratio, "standin.walks")

    @numba.njit
    def caller(x, y):
        return ratio_apart(x, y)

    assert caller(1.0, 0.0) == math.inf
    assert ratio_apart(1.0, 4.0) == 0.25  # from Python: the function itself
    with pytest.raises(ZeroDivisionError):
        ratio(1.0, 0.0)  # the function itself, from Python: Python's rules


def test_apart_refuses_keywords_and_defaults():
    def with_default(x, y=1.0):
        return x + y

    with pytest.raises(ValueError, match="only positional arguments without defaults"):
        apart(with_default, "standin.walks")
