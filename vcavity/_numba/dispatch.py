"""Compile-time dispatch over a registry of modules (used by the two registries), and
functions compiled apart from their callers.

``dispatcher(modules, op, argnames)`` returns a Python function ``op(kind, *argnames)``
that calls ``modules[kind].op``. In jitted code it is a Numba overload:

- for a compile-time constant ``kind`` (an integer literal: a closure int, as the kernel
  factory uses, or ``numba.literally(kind)``) it calls ``modules[kind].op`` itself, no
  branch, compiled apart (see below); this is how the kernel specialises;
- for a run-time integer ``kind`` it inlines a chain ``if kind == 0: ... elif ...`` over
  every registered module, so one compiled function serves all kinds (the analytic
  models use this: one compile instead of one per kind). The chain has no branch for an
  out-of-range kind (a ``raise`` would keep Numba from parallelising the callers'
  ``prange`` loops); kinds come only from the registry's ``kind_of``/``params_from``, and
  the registries' Python entry points check the range (:func:`check_kind`).

Callers stay cacheable: nothing here lands in their closures.

The overload prefers literal types (``prefer_literal=True``). Numba's default tries an
overload with the arguments' non-literal types first, and the run-time chain types for a
plain integer: a constant ``kind`` then got the whole chain, every registered module's
``op`` typed, inlined and lowered into the caller, to be folded away by LLVM at the end
(a third of a variant's cold compile: docs/performance.md, "Figures from the code's comments").

**Compiled apart, inlined by LLVM.** A constant kind's call, and a function given to
:func:`apart`, is compiled once per caller's compile as a function of its own
(``inline="never"``) that LLVM inlines (``forceinline``), instead of Numba inlining its IR
(``inline="always"``). Numba compiles an ``inline="always"`` overload in full anyway, then
types and lowers its IR again inside every caller, and every level of such inlining
repeats the work of the levels below (what compiling the facet event, the distribution's
sampler and the walk apart saves: docs/performance.md, "Figures from the code's comments"). The walk's speed is unchanged under
two conditions, both measured: the functions apart use NumPy's error model (``error_model
="numpy"``, as Numba's parallel loops do: no test and raise for a division by zero), and
their callers pass arrays as :func:`vcavity._numba.arrays.borrowed` views (no reference
counting per call).

Numba matches an overload's typing function, implementation and the overloaded Python
function by their argument names, so the three small wrappers are generated with
``exec`` for the given fixed argument list (Numba's inliner does not take ``*args``).
"""

from __future__ import annotations

import inspect
import keyword
import math

from numba import types
from numba.core import errors
from numba.extending import overload

#: Compiler options of the functions compiled apart (see the module docstring).
APART = {"forceinline": True, "error_model": "numpy"}


def check_kind(modules: tuple, kind, owner: str) -> int:
    """``kind`` as an int, or ``ValueError`` when it is not a position in ``modules``."""
    if isinstance(kind, bool) or not isinstance(kind, (int,)) and not hasattr(kind, "__index__"):
        raise ValueError(f"{owner}: kind = {kind!r}: must be an integer in [0, {len(modules)})")
    value = int(kind)
    if not 0 <= value < len(modules):
        raise ValueError(f"{owner}: kind = {kind!r}: must be in [0, {len(modules)}) (registered: "
                         f"{', '.join(m.NAME for m in modules)})")
    return value


def dispatcher(modules: tuple, op: str, argnames: tuple[str, ...], owner: str, missing: str | None = None,
               direct: bool = False):
    """A compile-time dispatched ``op(kind, *argnames)`` over ``modules``.

    Parameters
    ----------
    modules : tuple of modules
        The registry; ``kind`` is a position in it.
    op : str
        Name of the function every module defines.
    argnames : tuple of str
        Argument names of that function (fixed arity).
    owner : str
        Dotted name of the registry, for error messages.
    missing : str, optional
        For an optional ``op``: the expression (of ``math`` and literals) returned for a module
        without it (for a constant kind and in the run-time chain alike), e.g.
        ``"(math.nan, math.nan)"``, a value its callers recognise as invalid. Without it every
        module must define ``op``.

    Returns
    -------
    function
        Callable from Python (any ``kind``) and from jitted code (constant ``kind``).
    """
    for name in (op, *argnames):
        if not name.isidentifier() or keyword.iskeyword(name):
            raise ValueError(f"not an identifier: {name!r}")
    args = ", ".join(argnames)

    def resolve_constant(kind):
        return resolve(kind) if isinstance(kind, types.IntegerLiteral) else None

    def resolve_variable(kind):
        return None if isinstance(kind, types.IntegerLiteral) else resolve(kind)

    def resolve(kind):
        if isinstance(kind, types.IntegerLiteral):
            module = modules[kind.literal_value]
            scope = {"math": math}
            if missing is not None and not hasattr(module, op):
                exec(f"def call(kind, {args}):\n    return {missing}\n", scope)
            elif direct:
                return getattr(getattr(module, op), "py_func", getattr(module, op))
            else:
                scope["implementation"] = getattr(module, op)
                exec(f"def call(kind, {args}):\n    return implementation({args})\n", scope)
            return scope["call"]
        if not isinstance(kind, types.Integer):
            raise errors.TypingError(f"{owner}.{op}: the kind must be an integer; got {kind}")
        scope = {f"implementation_{k}": getattr(module, op) for k, module in enumerate(modules)
                 if missing is None or hasattr(module, op)}
        scope["math"] = math

        call_args = f"kind, {args}" if direct else args

        def result(k):
            return f"implementation_{k}({call_args})" if f"implementation_{k}" in scope else missing

        body = [f"def call(kind, {args}):"]
        for k in range(len(modules) - 1):
            body.append(f"    {'if' if k == 0 else 'elif'} kind == {k}:")
            body.append(f"        return {result(k)}")
        body.append(f"    return {result(len(modules) - 1)}")
        exec("\n".join(body) + "\n", scope)
        return scope["call"]

    scope = {"modules": modules, "resolve_constant": resolve_constant, "resolve_variable": resolve_variable,
             "check_kind": check_kind, "owner": f"{owner}.{op}"}
    exec(f"def {op}(kind, {args}):\n    return modules[check_kind(modules, kind, owner)].{op}("
         f"{'kind, ' if direct else ''}{args})\n"
         f"def typer_constant(kind, {args}):\n    return resolve_constant(kind)\n"
         f"def typer_variable(kind, {args}):\n    return resolve_variable(kind)\n", scope)
    function = scope[op]
    function.__doc__ = (f"``modules[kind].{op}({args})`` of {owner}; in jitted code ``kind`` must be a "
                        "compile-time constant.")
    function.__module__ = owner
    # two overloads, each answering only its own case: a constant kind compiled apart, the
    # run-time chain inlined into its caller (the analytic models' parallel loops)
    overload(function, inline="never", prefer_literal=True, jit_options=APART)(scope["typer_constant"])
    overload(function, inline="always", prefer_literal=True)(scope["typer_variable"])
    return function


def apart(function, owner: str):
    """``function`` compiled apart from its jitted callers and inlined by LLVM.

    Parameters
    ----------
    function : numba dispatcher
        Typically ``njit(inline="always")``: its own callees are inlined into it once.
    owner : str
        Dotted name, for the returned function's ``__module__``.

    Returns
    -------
    function
        Callable from Python (calls ``function``) and from jitted code, where it is compiled
        once per caller's compile and argument types, compile-time constants (integer
        literals: a kernel's closure ints) kept as such, so that the registries' dispatch
        inside it sees constant kinds. Compiler options :data:`APART`: pass arrays as
        :func:`vcavity._numba.arrays.borrowed` views from hot loops.
    """
    python_function = getattr(function, "py_func", function)
    parameters = inspect.signature(python_function).parameters.values()
    if any(p.kind not in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) or p.default is not p.empty for p in parameters):
        raise ValueError(f"{python_function.__name__}: only positional arguments without defaults")
    args = ", ".join(p.name for p in parameters)
    # the overload's implementation is the function's own Python code (same argument
    # names, as Numba requires): no wrapper, no inlining level of its own
    scope = {"implementation": function, "python_function": python_function}
    exec(f"def {function.__name__}({args}):\n    return implementation({args})\n"
         f"def typer({args}):\n    return python_function\n", scope)
    entry = scope[function.__name__]
    entry.__doc__ = function.__doc__
    entry.__module__ = owner
    overload(entry, inline="never", prefer_literal=True, jit_options=APART)(scope["typer"])
    return entry
