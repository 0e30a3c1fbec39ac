"""Compile-time dispatch over a registry of modules (used by the two registries).

``dispatcher(modules, op, argnames)`` returns a Python function ``op(kind, *argnames)``
that calls ``modules[kind].op``. In jitted code it is a Numba overload that needs
``kind`` as a compile-time constant (an integer literal: a closure int, or
``numba.literally(kind)``) and inlines ``modules[kind].op`` itself: no branch, no
function pointer, and callers stay cacheable (nothing here lands in their closures).

Numba matches an overload's typing function, implementation and the overloaded Python
function by their argument names, so the three small wrappers are generated with
``exec`` for the given fixed argument list (Numba's inliner does not take ``*args``).
"""

from __future__ import annotations

import keyword

from numba import types
from numba.core import errors
from numba.extending import overload


def dispatcher(modules: tuple, op: str, argnames: tuple[str, ...], owner: str):
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
        if not isinstance(kind, types.IntegerLiteral):
            raise errors.TypingError(
                f"{owner}.{op}: the kind must be a compile-time constant (a closure int, or "
                f"numba.literally(kind)); got {kind}")
        scope = {"implementation": getattr(modules[kind.literal_value], op)}
        exec(f"def call(kind, {args}):\n    return implementation({args})\n", scope)
        return scope["call"]

    scope = {"modules": modules, "resolve": resolve}
    exec(f"def {op}(kind, {args}):\n    return modules[kind].{op}({args})\n"
         f"def typer(kind, {args}):\n    return resolve(kind)\n", scope)
    function = scope[op]
    function.__doc__ = (f"``modules[kind].{op}({args})`` of {owner}; in jitted code ``kind`` must be a "
                        "compile-time constant.")
    function.__module__ = owner
    overload(function, inline="always")(scope["typer"])
    return function
