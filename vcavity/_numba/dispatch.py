"""Compile-time dispatch over a registry of modules (used by the two registries).

``dispatcher(modules, op, argnames)`` returns a Python function ``op(kind, *argnames)``
that calls ``modules[kind].op``. In jitted code it is a Numba overload:

- for a compile-time constant ``kind`` (an integer literal: a closure int, as the kernel
  factory uses, or ``numba.literally(kind)``) it inlines ``modules[kind].op`` itself: no
  branch, no function pointer; this is how the kernel specialises;
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
``op`` typed, inlined and lowered into the caller, to be folded away by LLVM at the end.
The default variant's cold compile spent 12.7 s of CPU on that, 8.0 s with literals first
(docs/performance.md, "Compile time: literal kinds first").

Numba matches an overload's typing function, implementation and the overloaded Python
function by their argument names, so the three small wrappers are generated with
``exec`` for the given fixed argument list (Numba's inliner does not take ``*args``).
"""

from __future__ import annotations

import keyword
import math

from numba import types
from numba.core import errors
from numba.extending import overload


def check_kind(modules: tuple, kind, owner: str) -> int:
    """``kind`` as an int, or ``ValueError`` when it is not a position in ``modules``."""
    if isinstance(kind, bool) or not isinstance(kind, (int,)) and not hasattr(kind, "__index__"):
        raise ValueError(f"{owner}: kind = {kind!r}: must be an integer in [0, {len(modules)})")
    value = int(kind)
    if not 0 <= value < len(modules):
        raise ValueError(f"{owner}: kind = {kind!r}: must be in [0, {len(modules)}) (registered: "
                         f"{', '.join(m.NAME for m in modules)})")
    return value


def dispatcher(modules: tuple, op: str, argnames: tuple[str, ...], owner: str, missing: str | None = None):
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

    def resolve(kind):
        if isinstance(kind, types.IntegerLiteral):
            module = modules[kind.literal_value]
            scope = {"math": math}
            if missing is not None and not hasattr(module, op):
                exec(f"def call(kind, {args}):\n    return {missing}\n", scope)
            else:
                scope["implementation"] = getattr(module, op)
                exec(f"def call(kind, {args}):\n    return implementation({args})\n", scope)
            return scope["call"]
        if not isinstance(kind, types.Integer):
            raise errors.TypingError(f"{owner}.{op}: the kind must be an integer; got {kind}")
        scope = {f"implementation_{k}": getattr(module, op) for k, module in enumerate(modules)
                 if missing is None or hasattr(module, op)}
        scope["math"] = math

        def result(k):
            return f"implementation_{k}({args})" if f"implementation_{k}" in scope else missing

        body = [f"def call(kind, {args}):"]
        for k in range(len(modules) - 1):
            body.append(f"    {'if' if k == 0 else 'elif'} kind == {k}:")
            body.append(f"        return {result(k)}")
        body.append(f"    return {result(len(modules) - 1)}")
        exec("\n".join(body) + "\n", scope)
        return scope["call"]

    scope = {"modules": modules, "resolve": resolve, "check_kind": check_kind, "owner": f"{owner}.{op}"}
    exec(f"def {op}(kind, {args}):\n    return modules[check_kind(modules, kind, owner)].{op}({args})\n"
         f"def typer(kind, {args}):\n    return resolve(kind)\n", scope)
    function = scope[op]
    function.__doc__ = (f"``modules[kind].{op}({args})`` of {owner}; in jitted code ``kind`` must be a "
                        "compile-time constant.")
    function.__module__ = owner
    overload(function, inline="always", prefer_literal=True)(scope["typer"])
    return function
