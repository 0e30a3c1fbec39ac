"""A registry of interchangeable modules: registration, lookup by name and dispatch.

The distributions of normals (:mod:`vcavity.microfacet.registry`) and the facet models
(:mod:`vcavity.facet.registry`) are each one :class:`Registry`: a tuple of module names
under one package, every module offering the same interface (``NAME``, ``DESCRIPTION``,
``PARAMETERS`` and the functions the registry documents). So adding a distribution or a
facet model is a new module plus one line in that tuple; the lookup, parameter parsing,
``--help`` text and jitted dispatch below serve it with no other edit.

``kind``, a module's position in the tuple, is what jitted code receives: the
operations :meth:`Registry.dispatcher` builds resolve a compile-time constant ``kind``
to the module's own function (see :mod:`vcavity._numba.dispatch`).

Plain Python: nothing here is jitted.
"""

from __future__ import annotations

import importlib
from typing import Any, Mapping

from vcavity._numba.dispatch import check_kind, dispatcher
from vcavity.parameters import accepted_keys, canonical_keys, parse_parameters


class Registry:
    """The modules of one package that share an interface, in dispatch order.

    Parameters
    ----------
    package : str
        Dotted package holding the modules, e.g. ``"vcavity.microfacet"``.
    module_names : tuple of str
        Module names under ``package``; a module's position is its ``kind``.
    noun : str
        What one module is, in parse errors and interface errors (``"distribution"``).
    title : str
        The same for unknown-name errors (``"microfacet distribution"``).
    interface : tuple of str
        Attributes every module must have; a missing one is an ``ImportError`` at import.
    owner : str
        Dotted name of the registry module, for error messages and the dispatchers.

    Attributes
    ----------
    modules : tuple of modules
        The imported modules; lookups read it at call time, so a test may replace it.
    """

    def __init__(self, package: str, module_names: tuple[str, ...], *, noun: str, title: str,
                 interface: tuple[str, ...], owner: str):
        self.package = package
        self.module_names = tuple(module_names)
        self.noun = noun
        self.title = title
        self.owner = owner
        self.modules = tuple(importlib.import_module(f"{package}.{name}") for name in self.module_names)
        for module in self.modules:
            missing = [attr for attr in interface if not hasattr(module, attr)]
            if missing:
                raise ImportError(f"{noun} module {module.__name__} lacks {', '.join(missing)}")
        names = [module.NAME for module in self.modules]
        if len(set(names)) != len(names):  # a second module of one name could never be selected
            raise ImportError(f"{owner}: {noun} names registered twice: {', '.join(names)}")

    @property
    def names(self) -> tuple[str, ...]:
        """``NAME`` of every module, in dispatch order."""
        return tuple(module.NAME for module in self.modules)

    def get(self, name: str):
        """The module called ``name``.

        Parameters
        ----------
        name : str
            A registered ``NAME``.

        Returns
        -------
        module

        Raises
        ------
        KeyError
            For an unknown name; the message lists the registered ones.
        """
        for module in self.modules:
            if module.NAME == name:
                return module
        raise KeyError(f"unknown {self.title} {name!r}; registered: {', '.join(self.names)}")

    def kind_of(self, name: str) -> int:
        """Dispatch index (position in :attr:`modules`) of the module ``name``; ``KeyError`` if unknown."""
        return self.modules.index(self.get(name))

    def parse(self, name: str, raw: Mapping[str, Any], table: str = "material") -> dict[str, float]:
        """Validated canonical parameter values of module ``name`` from a user table.

        Only the module's own keys are read; the caller rejects unknown keys.

        Parameters
        ----------
        name : str
            A registered ``NAME``.
        raw : mapping
            The user's table (``[material]``).
        table : str
            Its name, for error messages.

        Returns
        -------
        dict of str to float

        Raises
        ------
        vcavity.parameters.ParameterError
            One line naming the field, the value and what is accepted.
        """
        return parse_parameters(self.get(name).PARAMETERS, raw, table, f"{self.noun} {name!r}")

    def config_keys(self, name: str) -> tuple[str, ...]:
        """Config keys the module ``name`` accepts."""
        return accepted_keys(self.get(name).PARAMETERS)

    def value_keys(self, name: str) -> tuple[str, ...]:
        """Keys of the canonical values of ``name`` (what tables store in ``/material``)."""
        return canonical_keys(self.get(name).PARAMETERS)

    def help_lines(self) -> list[str]:
        """``--help`` text: one block per module (description, then one line per parameter)."""
        lines = []
        for module in self.modules:
            lines.append(f"{module.NAME}: {module.DESCRIPTION}")
            lines.extend(f"    {spec.help()}" for spec in module.PARAMETERS)
        return lines

    def check_kind(self, kind, where: str) -> int:
        """``kind`` as an int, or ``ValueError`` (naming ``owner.where``) when it is not a dispatch index."""
        return check_kind(self.modules, kind, f"{self.owner}.{where}")

    def dispatcher(self, op: str, argnames: tuple[str, ...], missing: str | None = None, direct: bool = False):
        """``op(kind, *argnames)``: every module's function ``op``, dispatched on ``kind``.

        Parameters
        ----------
        op : str
            Name of the function every module defines.
        argnames : tuple of str
            Its argument names (fixed arity).
        missing : str, optional
            For an optional ``op``, what a module without it returns in the run-time chain
            (:func:`vcavity._numba.dispatch.dispatcher`).
        direct : bool, optional
            Every module's ``op`` takes ``kind`` first: a constant kind compiles the module's
            own code apart, no wrapper level (:func:`vcavity._numba.dispatch.dispatcher`).

        Returns
        -------
        function
            Callable from Python and from jitted code (:func:`vcavity._numba.dispatch.dispatcher`).
        """
        return dispatcher(self.modules, op, argnames, self.owner, missing, direct)


__all__ = ["Registry"]
