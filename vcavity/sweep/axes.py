"""The axes of a sweep file (docs/sweeps.md): plain ``[sweep]`` lists and paired axes.

An axis that indexes points (every axis but the incident angles) is a :class:`PointAxis`:
a plain axis ``alpha = [...]`` sets its own key, a paired axis sets several keys together.
A plain ``[sweep]`` axis varies one key, and the grid is the product of the axes. Some
parameters only make sense point by point: the complex index ``eta + i k`` of a metal
at each wavelength, for an RGB or spectral material. A *paired* axis is a sub-table of
``[sweep.paired]`` with equal-length lists, one label list naming its points and one
list per parameter it sets::

    [sweep.paired.wavelength]
    label_nm = [659.5, 548.6, 450.9]   # the axis values (units after "label_", here nm)
    eta = [0.14, 0.43, 1.38]           # point j sets eta = eta[j] and k = k[j] together
    k = [3.697, 2.455, 1.914]

In the grid it is one axis (named ``wavelength``, values the labels); the lists of
parameters are stored beside it in the sweep file, as coordinates along that axis
(docs/sweeps.md, "Paired axes"). This module checks a ``[sweep.paired]`` table's shape;
the values themselves are validated at each point like every other axis
(:mod:`vcavity.sweep.spec`). Errors are :class:`ValueError` with one line naming the
field as written; the spec turns them into its ``SweepError``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vcavity.facet import registry as facets
from vcavity.io.sweep_table import INCIDENCE_AXES, GridAxis
from vcavity.microfacet import registry as distributions

#: The key of the label list is ``label`` or ``label_<units>``.
LABEL = "label"


@dataclass(frozen=True)
class PointAxis:
    """An axis of points: its name, labels (the axis values), their units and the lists it sets.

    A plain axis (:func:`plain_axis`) has ``label_key = ""``: its labels are the values
    of its one key.

    Attributes
    ----------
    name : str
        The sub-table's name (``wavelength``): the grid axis's name.
    label_key : str
        ``label`` or ``label_<units>`` as written.
    labels : tuple
        The axis values, one per point of the axis.
    settings : tuple of (str, tuple)
        ``(key, values)`` per parameter the axis sets, in the order written.
    """

    name: str
    label_key: str
    labels: tuple
    settings: tuple

    @property
    def field(self) -> str:
        """The axis as written: ``sweep.paired.NAME``."""
        return f"sweep.paired.{self.name}"

    @property
    def units(self) -> str | None:
        """Units of the labels: the suffix of ``label_<units>``, None for a bare ``label``."""
        return self.label_key[len(LABEL) + 1:] or None

    @property
    def keys(self) -> tuple[str, ...]:
        """The parameters it sets."""
        return tuple(key for key, _ in self.settings)

    def __len__(self) -> int:
        return len(self.labels)

    def values_at(self, j: int) -> dict[str, Any]:
        """``{key: value}`` that point ``j`` of the axis sets."""
        return {key: values[j] for key, values in self.settings}


def _fail(field: str, value: Any, accepted: str):
    raise ValueError(f"{field} = {value!r}: {accepted}")


def _is_label(key: str) -> bool:
    return key == LABEL or (key.startswith(LABEL + "_") and len(key) > len(LABEL) + 1)


def _one_axis(name: str, table: Any, accepted_keys: tuple[str, ...], taken: dict[str, str]) -> PointAxis:
    field = f"sweep.paired.{name}"
    example = "label_nm = [650, 550, 450] and eta = [...], k = [...] of the same length"
    if not isinstance(table, dict):
        _fail(field, table, f"must be a table of equal-length lists, e.g. {example}")
    labels = [key for key in table if _is_label(key)]
    if len(labels) != 1:
        _fail(field, table, f"needs exactly one label list (label or label_<units>) naming its points, e.g. {example}")
    label_key = labels[0]
    if len(table) < 2:
        _fail(field, table, f"sets no parameter; give the lists it sets beside {label_key}, e.g. {example}")
    n = None
    for key, values in table.items():
        where = f"{field}.{key}"
        if key != label_key and key not in accepted_keys:
            _fail(where, values, f"not a parameter a paired axis can set; accepted: {', '.join(accepted_keys)} "
                                 f"and one label list (label or label_<units>)")
        if key in taken:
            _fail(where, values, f"{key} is already swept by {taken[key]}; each parameter can be set by one axis")
        if not isinstance(values, list) or not values:
            _fail(where, values, f"must be a non-empty list of values, e.g. {key} = [a, b]")
        for i, value in enumerate(values):
            if isinstance(value, (list, dict)):
                _fail(f"{where}[{i}]", value, "must be a single value")
        if n is None:
            n = len(values)
        elif len(values) != n:
            _fail(where, values, f"has {len(values)} values, {field}.{label_key} has {n}; the lists of a "
                                 f"paired axis must have the same length (point j takes the j-th value of each)")
        if key != label_key:
            taken[key] = field
    return PointAxis(name=name, label_key=label_key, labels=tuple(table[label_key]),
                      settings=tuple((k, tuple(v)) for k, v in table.items() if k != label_key))


def parse_paired(paired: Any, accepted_keys: tuple[str, ...], plain_axes: tuple[str, ...]) -> tuple[PointAxis, ...]:
    """The paired axes of a ``[sweep.paired]`` table, checked in shape.

    Parameters
    ----------
    paired : Any
        ``raw["sweep"]["paired"]`` as parsed from TOML.
    accepted_keys : tuple of str
        The keys a paired axis may set (the point parameters: ``distribution`` and every
        registered parameter).
    plain_axes : tuple of str
        The plain ``[sweep]`` axes: their keys and names are taken.

    Raises
    ------
    ValueError
        One line naming the field as written (``sweep.paired.wavelength.k``): not a
        table, no or several label lists, an unknown or twice-swept key, lists of
        different lengths, an axis named like another axis.
    """
    if not isinstance(paired, dict) or not paired:
        _fail("sweep.paired", paired, "must hold at least one named table of equal-length lists, "
                                      "e.g. [sweep.paired.wavelength] label_nm = [...], eta = [...], k = [...]")
    taken = {key: f"sweep.{key}" for key in plain_axes}
    axes = []
    for name, table in paired.items():
        if name in taken or name in accepted_keys:
            _fail(f"sweep.paired.{name}", table, "a paired axis needs a name of its own, not the name of a "
                                                 "parameter or of another axis (e.g. wavelength)")
        axes.append(_one_axis(name, table, accepted_keys, taken))
        taken[name] = f"sweep.paired.{name}"
    return tuple(axes)


def material_keys() -> tuple[str, ...]:
    """Every parameter key of every registered distribution and facet model, once each."""
    keys = [k for name in distributions.NAMES for k in distributions.config_keys(name)]
    keys += [k for name in facets.NAMES for k in facets.config_keys(name)]
    return tuple(dict.fromkeys(keys))


def axis_keys() -> tuple[str, ...]:
    """Keys a ``[sweep]`` table accepts: microsurface, distribution, every registered
    parameter, the angles."""
    return ("microsurface", "distribution") + material_keys() + INCIDENCE_AXES


def parameter_spec(key: str, material: dict):
    """The declaration of parameter ``key``: the base material's facet model's and
    distribution's first (``eta`` and ``alpha`` are declared by more than one module), then
    any distribution's or facet model's."""
    facet = material.get("facet", "interfaced_lambertian")
    distribution = material.get("distribution", "beckmann")
    modules = (((facets.get(facet),) if facet in facets.NAMES else ())
               + ((distributions.get(distribution),) if distribution in distributions.NAMES else ())
               + distributions.MODULES + facets.MODULES)
    for module in modules:
        for spec in module.PARAMETERS:
            if key in spec.keys:
                return spec
    return None


def units_and_name(key: str, material: dict) -> tuple[str | None, str]:
    """Units and long name of an axis or a paired list named ``key`` (from its declaration)."""
    if key == "distribution":
        return None, "microfacet distribution"
    if key == "microsurface":
        return None, "microsurface (v-cavity or smith)"
    if key in INCIDENCE_AXES:
        return "degree", "incident polar angle" if key == "theta_i_deg" else "incident azimuth"
    spec = parameter_spec(key, material)
    return getattr(spec, "units", "1"), spec.summary


def grid_axis(key: str, values, material: dict) -> GridAxis:
    """A grid axis with units and a long name from the parameter's declaration (in the base
    ``material``'s distribution and facet model first)."""
    return GridAxis(key, tuple(values), *units_and_name(key, material))


def paired_grid_axis(axis: PointAxis, material: dict) -> GridAxis:
    """A paired axis: its labels, and each list it sets as a coordinate along it."""
    paired = tuple((key, values, *units_and_name(key, material)) for key, values in axis.settings)
    return GridAxis(axis.name, axis.labels, axis.units, f"paired axis setting {', '.join(axis.keys)}", paired=paired)


def plain_axis(key: str, values) -> PointAxis:
    """A plain ``[sweep]`` axis as a point axis that sets its own key."""
    return PointAxis(name=key, label_key="", labels=tuple(values), settings=((key, tuple(values)),))


def setter_field(axis: PointAxis, key: str) -> str:
    """The list that sets ``key`` as written: ``sweep.KEY`` or ``sweep.paired.NAME.KEY``."""
    return f"sweep.{key}" if not axis.label_key else f"{axis.field}.{key}"


def point_axes(written: dict, table: dict, paired: tuple[PointAxis, ...]) -> tuple[PointAxis, ...]:
    """Every axis but the incidence ones, in the order written (paired axes where
    ``paired`` stands in ``[sweep]``; after the plain keys when written as sub-tables)."""
    axes = []
    for key in written:
        if key == "paired":
            axes.extend(paired)
        elif key in table and key not in INCIDENCE_AXES:
            axes.append(plain_axis(key, table[key]))
    return tuple(axes)


def grid_names(written: dict, paired: tuple[PointAxis, ...]) -> list[str]:
    """The grid axes in file order: ``[sweep]`` as written (a paired axis by its name),
    then ``theta_i_deg`` when not swept."""
    names = [name for key in written for name in ([a.name for a in paired] if key == "paired" else [key])]
    return names + ([] if "theta_i_deg" in written else ["theta_i_deg"])


__all__ = ["LABEL", "PointAxis", "axis_keys", "grid_axis", "grid_names", "material_keys", "paired_grid_axis",
           "parameter_spec", "parse_paired", "plain_axis", "point_axes", "setter_field", "units_and_name"]
