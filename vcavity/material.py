"""What a scene is made of: a microsurface, its distribution of normals and its facet model.

A :class:`Material` holds the validated canonical parameter values of a registered
distribution (:mod:`vcavity.microfacet.registry`) and facet model
(:mod:`vcavity.facet.registry`), and which microsurface they make: V-grooves or Smith's
uncorrelated heights and slopes. The walks, the analytic models and the estimators take
it as it is; a run config (:mod:`vcavity.config`) and a table's ``/material`` group are
both validated here, with :class:`ConfigError` messages of one line naming the field as
the user wrote it, the value and what is accepted.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.parameters import ConfigError, ParameterError, fail

#: The microsurfaces a material can have: V-grooves (the default) or Smith's uncorrelated
#: heights and slopes, walked by Heitz et al. 2016 (physics.md sec. 5 and 15).
MICROSURFACES = ("v-cavity", "smith")
DEFAULT_MICROSURFACE = "v-cavity"

@dataclass(frozen=True)
class Material:
    """Microsurface: a distribution of V-groove normals and a facet model, each with its
    own validated parameters (canonical keys, as the registries define them).

    Attributes
    ----------
    distribution : str
        A registered distribution (:mod:`vcavity.microfacet.registry`).
    facet : str
        A registered facet model (:mod:`vcavity.facet.registry`).
    distribution_params : dict
        Canonical parameter values of the distribution (e.g. ``alpha_x``, ``alpha_y``).
    facet_params : dict
        Canonical parameter values of the facet model (e.g. ``kd``, ``eta``; mirror: none).
    microsurface : str
        One of :data:`MICROSURFACES`: V-grooves (default) or the Smith microsurface.
    """

    distribution: str
    facet: str
    distribution_params: dict = dataclasses.field(default_factory=dict)
    facet_params: dict = dataclasses.field(default_factory=dict)
    microsurface: str = DEFAULT_MICROSURFACE

    @property
    def isotropic(self) -> bool:
        """True when the table cannot depend on phi_i."""
        return distributions.is_isotropic(self.distribution, self.distribution_params)

    def to_dict(self) -> dict[str, Any]:
        """Flat ``{"distribution", <its parameters>, "facet", <its parameters>}`` (what tables
        store), with ``"microsurface"`` first when it is not the default V-cavity (so V-cavity
        tables are what they were before the Smith walk existed)."""
        surface = {} if self.microsurface == DEFAULT_MICROSURFACE else {"microsurface": self.microsurface}
        return {**surface, "distribution": self.distribution, **self.distribution_params, "facet": self.facet,
                **self.facet_params}

    @classmethod
    def from_dict(cls, values: dict[str, Any], table: str = "material") -> "Material":
        """Validate a flat material dict (config ``[material]`` or a table's ``/material``).

        Raises
        ------
        ConfigError
            One line naming the field, the value and what is accepted.
        """
        return validate_material(dict(values), table)


def _owner_of(key: str) -> str | None:
    """Which kind of component declares config key ``key`` (for messages), if any."""
    if any(key in distributions.config_keys(name) for name in distributions.NAMES):
        return "distribution"
    if any(key in facets.config_keys(name) for name in facets.NAMES):
        return "facet"
    return None


def validate_material(raw: dict, table: str = "material") -> Material:
    """The :class:`Material` of a ``[material]`` table (or a table's ``/material``).

    Raises
    ------
    ConfigError
        One line naming the field (``{table}.key``), the value and what is accepted.
    """
    if not isinstance(raw, dict):
        fail(table, raw, "must be a TOML table")
    dist = raw.get("distribution", "beckmann")
    if dist not in distributions.NAMES:
        fail(f"{table}.distribution", dist, f"accepted: {', '.join(distributions.NAMES)}")
    facet = raw.get("facet", "interfaced_lambertian")
    if facet not in facets.NAMES:
        fail(f"{table}.facet", facet, f"accepted: {', '.join(facets.NAMES)}")
    surface = raw.get("microsurface", DEFAULT_MICROSURFACE)
    if surface not in MICROSURFACES:
        fail(f"{table}.microsurface", surface, f"accepted: {', '.join(MICROSURFACES)}")
    if surface == "smith" and distributions.smith_walk_refusal(dist) is not None:
        fail(f"{table}.microsurface", surface, f"with distribution {dist!r}: "
              f"{distributions.smith_walk_refusal(dist)}")
    dist_keys = distributions.config_keys(dist)
    facet_keys = facets.config_keys(facet)
    for key, value in raw.items():
        if key in ("microsurface", "distribution", "facet") or key in dist_keys or key in facet_keys:
            continue
        owner = _owner_of(key)
        if owner == "distribution":
            fail(f"{table}.{key}", value, f"not a parameter of distribution {dist!r} "
                  f"(it takes: {', '.join(dist_keys) or 'nothing'})")
        if owner == "facet":
            fail(f"{table}.{key}", value, f"not used by facet {facet!r} "
                  f"(it takes: {', '.join(facet_keys) or 'nothing'})")
        accepted = ("microsurface", "distribution", *dist_keys, "facet", *facet_keys)
        fail(f"{table}.{key}", value, f"unknown key; accepted keys: {', '.join(accepted)}")
    try:
        return Material(distribution=dist, facet=facet,
                        distribution_params=distributions.parse(dist, raw, table),
                        facet_params=facets.parse(facet, raw, table), microsurface=surface)
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None


__all__ = ["ConfigError", "DEFAULT_MICROSURFACE", "MICROSURFACES", "Material", "validate_material"]
