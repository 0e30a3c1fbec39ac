"""The one place facet models are registered and dispatched (physics.md sec. 4).

Adding a facet model is a new module in ``vcavity/facet/`` with the interface below plus
one line in :data:`FACET_MODULES`.

Interface of a facet module
---------------------------
``NAME``, ``DESCRIPTION`` (one line), ``PARAMETERS`` (:mod:`vcavity.parameters` specs),
``VARIANTS`` (names of its compiled variants),
``EXAMPLES`` (a dict of named parameter sets, each a dict of config keys as a user writes
them in ``[material]``, e.g. ``{"typical": {"kd": 0.9, "eta": 1.5}, "dielectric": {"kd": 0.0},
...}``; the first is the typical one, which stands for the module where one set is enough;
checked at import: identifier-like names, only the module's own keys, each accepted by
:func:`parse`, and together selecting every variant. tests/facet/test_conformance.py runs
every generic check of the interface on every registered module and example: no test file
lists the facet models), and

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
compile-time constant (see :mod:`vcavity._numba.dispatch`). Lookup, parsing and dispatch
are one :class:`vcavity._numba.registry.Registry` (:data:`REGISTRY`).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from vcavity._numba.registry import Registry
from vcavity.parameters import ParameterError

#: Registered facet models, by module name under ``vcavity.facet``: one line each.
FACET_MODULES = (
    "interfaced_lambertian",
    "mirror",
    "conductor",
)

REGISTRY = Registry(
    "vcavity.facet", FACET_MODULES, noun="facet", title="facet model",
    interface=("NAME", "DESCRIPTION", "PARAMETERS", "VARIANTS", "EXAMPLES", "variant", "prepare", "event",
               "reflectance", "transmittance", "has_specular", "body_factor"),
    owner="vcavity.facet.registry")


def _check_examples(module) -> None:
    """``ImportError`` unless ``module.EXAMPLES`` is a dict of named ``[material]`` parameter
    sets, each with only the module's own keys and accepted by :func:`parse`, that together
    select every one of the module's ``VARIANTS``."""
    examples = module.EXAMPLES
    if not isinstance(examples, dict) or not examples:
        raise ImportError(f"{module.__name__}.EXAMPLES: a non-empty dict of named parameter sets")
    keys = set(REGISTRY.config_keys(module.NAME))
    selected = set()
    for label, raw in examples.items():
        where = f"{module.__name__}.EXAMPLES[{label!r}]"
        if not (isinstance(label, str) and label.isidentifier() and label.islower()):
            raise ImportError(f"{where}: names are lower-case identifiers")
        if not isinstance(raw, dict) or set(raw) - keys:
            raise ImportError(f"{where} = {raw!r}: a dict of the module's keys ({', '.join(sorted(keys)) or 'none'})")
        try:
            values = REGISTRY.parse(module.NAME, raw, table=where)
        except ParameterError as error:
            raise ImportError(str(error)) from None
        selected.add(module.VARIANTS[module.variant(values)])
    missing = [name for name in module.VARIANTS if name not in selected]
    if missing:
        raise ImportError(f"{module.__name__}.EXAMPLES select no example of the variant(s) {', '.join(missing)}")


for _module in REGISTRY.modules:
    _check_examples(_module)

MODULES = REGISTRY.modules
NAMES = REGISTRY.names
get = REGISTRY.get
kind_of = REGISTRY.kind_of
parse = REGISTRY.parse
config_keys = REGISTRY.config_keys
value_keys = REGISTRY.value_keys
help_lines = REGISTRY.help_lines


def prepare(name: str, values: Mapping[str, float]) -> tuple[int, int, np.ndarray]:
    """``(kind, variant, data)`` for the kernel."""
    kind = kind_of(name)
    module = REGISTRY.modules[kind]
    data = np.ascontiguousarray(module.prepare(values), dtype=np.float64)
    return kind, int(module.variant(values)), data


def variant_name(name: str, values: Mapping[str, float]) -> str:
    """Human name of the compiled variant the values select."""
    module = get(name)
    return module.VARIANTS[module.variant(values)]


def variant_examples() -> list[tuple[str, str, dict]]:
    """``(facet name, example label, example)``: every registered model's first example of
    each of its compiled variants (the examples select them all: checked at import), in
    registry and example order. The one list that stands for "every facet variant" in the
    stress grid and the tests."""
    out = []
    for module in MODULES:
        seen = set()
        for label, example in module.EXAMPLES.items():
            variant = module.variant(parse(module.NAME, example))
            if variant not in seen:
                seen.add(variant)
                out.append((module.NAME, label, example))
    return out


def has_specular(name: str, values: Mapping[str, float]) -> bool:
    """True when the facet reflects specularly at all."""
    return bool(get(name).has_specular(values))


def is_specular(name: str, values: Mapping[str, float]) -> bool:
    """True when every hit of the facet reflects specularly or absorbs (no body re-emits,
    no hit is random but for survival): mirror, conductor, interfaced Lambertian with
    ``kd = 0`` and ``eta > 1``. Their V-cavities have every order in closed form
    (physics.md sec. 12)."""
    return has_specular(name, values) and body_factor(name, values) == 0.0


def body_factor(name: str, values: Mapping[str, float]) -> float:
    """The constant ``K`` of the facet's body term ``K T(c_i) T(c_o)`` (0: no body)."""
    return float(get(name).body_factor(values))


event = REGISTRY.dispatcher("event", ("variant", "state", "dx", "dy", "dz", "cos_in", "nx", "nz", "data"))
reflectance = REGISTRY.dispatcher("reflectance", ("cos_theta", "data"))
transmittance = REGISTRY.dispatcher("transmittance", ("cos_theta", "data"))

__all__ = ["FACET_MODULES", "REGISTRY", "MODULES", "NAMES", "get", "kind_of", "parse", "config_keys", "value_keys",
           "prepare", "variant_name", "has_specular", "is_specular", "body_factor", "help_lines", "event", "reflectance",
           "transmittance"]
