"""The one place facet models are registered and dispatched (physics.md sec. 4).

Adding a facet model is a new module in ``vcavity/facet/`` with the interface below plus
one line in :data:`FACET_MODULES`.

Interface of a facet module
---------------------------
``NAME``, ``DESCRIPTION`` (one line), ``PARAMETERS`` (:mod:`vcavity.parameters` specs),
``VARIANTS`` (names of its compiled variants), and

- ``variant(values) -> int``: which compiled variant the values need (limits that skip
  work, e.g. no Fresnel at ``eta = 1``); a compile-time constant of the kernel;
- ``prepare(values) -> ndarray``: float64 facet data precomputed once per run;
- jitted ``event(variant, state, dx, dy, dz, cos_in, nx, nz, data) ->
  (state, outcome, dx, dy, dz)``: one facet hit of the analog walk, drawing from
  :mod:`vcavity.rng`; ``outcome`` is ``facet.common.SCATTERED`` or ``ABSORBED``;
- for the analytic single-bounce model, whose facet micro-BRDF is a specular delta of
  reflectance ``R(c)`` plus a body term ``K T(c_i) T(c_o)``: jitted
  ``reflectance(cos, data)``, ``transmittance(cos, data)``, and plain
  ``has_specular(values) -> bool``, ``body_factor(values) -> K``.

``kind`` is the position in :data:`FACET_MODULES`; the jitted operations need it as a
compile-time constant (see :mod:`vcavity._numba.dispatch`).
"""

from __future__ import annotations

import importlib
from typing import Any, Mapping

import numpy as np

from vcavity._numba.dispatch import dispatcher
from vcavity.parameters import accepted_keys, canonical_keys, parse_parameters

#: Registered facet models, by module name under ``vcavity.facet``: one line each.
FACET_MODULES = (
    "interfaced_lambertian",
    "mirror",
)

MODULES = tuple(importlib.import_module(f"vcavity.facet.{name}") for name in FACET_MODULES)
_BY_NAME = {module.NAME: module for module in MODULES}
NAMES = tuple(_BY_NAME)

_INTERFACE = ("NAME", "DESCRIPTION", "PARAMETERS", "VARIANTS", "variant", "prepare", "event",
              "reflectance", "transmittance", "has_specular", "body_factor")
for _module in MODULES:
    _missing = [attr for attr in _INTERFACE if not hasattr(_module, attr)]
    if _missing:
        raise ImportError(f"facet module {_module.__name__} lacks {', '.join(_missing)}")


def get(name: str):
    """The facet module called ``name``.

    Raises
    ------
    KeyError
        For an unknown name; the message lists the registered ones.
    """
    if name not in _BY_NAME:
        raise KeyError(f"unknown facet model {name!r}; registered: {', '.join(NAMES)}")
    return _BY_NAME[name]


def kind_of(name: str) -> int:
    """Dispatch index of the facet model ``name``."""
    return MODULES.index(get(name))


def parse(name: str, raw: Mapping[str, Any], table: str = "material") -> dict[str, float]:
    """Validated canonical parameter values of facet model ``name`` from a user table.

    Raises
    ------
    vcavity.parameters.ParameterError
        One line naming the field, the value and what is accepted.
    """
    return parse_parameters(get(name).PARAMETERS, raw, table, f"facet {name!r}")


def config_keys(name: str) -> tuple[str, ...]:
    """Config keys the facet model ``name`` accepts."""
    return accepted_keys(get(name).PARAMETERS)


def value_keys(name: str) -> tuple[str, ...]:
    """Keys of the canonical values of ``name`` (what tables store in ``/material``)."""
    return canonical_keys(get(name).PARAMETERS)


def prepare(name: str, values: Mapping[str, float]) -> tuple[int, int, np.ndarray]:
    """``(kind, variant, data)`` for the kernel."""
    module = get(name)
    data = np.ascontiguousarray(module.prepare(values), dtype=np.float64)
    return MODULES.index(module), int(module.variant(values)), data


def variant_name(name: str, values: Mapping[str, float]) -> str:
    """Human name of the compiled variant the values select."""
    module = get(name)
    return module.VARIANTS[module.variant(values)]


def has_specular(name: str, values: Mapping[str, float]) -> bool:
    """True when the facet reflects specularly at all."""
    return bool(get(name).has_specular(values))


def body_factor(name: str, values: Mapping[str, float]) -> float:
    """The constant ``K`` of the facet's body term ``K T(c_i) T(c_o)`` (0: no body)."""
    return float(get(name).body_factor(values))


def help_lines() -> list[str]:
    """``--help`` text: one block per facet model."""
    lines = []
    for module in MODULES:
        lines.append(f"{module.NAME}: {module.DESCRIPTION}")
        lines.extend(f"    {spec.help()}" for spec in module.PARAMETERS)
    return lines


_OWNER = "vcavity.facet.registry"
event = dispatcher(MODULES, "event", ("variant", "state", "dx", "dy", "dz", "cos_in", "nx", "nz", "data"),
                   _OWNER)
reflectance = dispatcher(MODULES, "reflectance", ("cos_theta", "data"), _OWNER)
transmittance = dispatcher(MODULES, "transmittance", ("cos_theta", "data"), _OWNER)

__all__ = ["FACET_MODULES", "MODULES", "NAMES", "get", "kind_of", "parse", "config_keys", "value_keys",
           "prepare", "variant_name", "has_specular", "body_factor", "help_lines", "event", "reflectance",
           "transmittance"]
