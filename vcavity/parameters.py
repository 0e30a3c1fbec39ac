"""Declared parameters of material components: config keys, accepted ranges, defaults, help;
the one-line errors of a parameter and of a config value.

Every distribution module (``vcavity/microfacet/``) and facet module (``vcavity/facet/``)
lists its parameters in a ``PARAMETERS`` tuple of the specs below. The config layer,
``--help``, reports and sweeps all read these declarations, so a parameter's key, range,
default and meaning are written once, beside the physics that uses them.

A spec turns the user's TOML values into canonical floats: :class:`Number` is one key,
:class:`Roughness` is ``alpha`` (isotropic) or ``alpha_x`` and ``alpha_y``
(anisotropic), stored canonically as ``alpha_x``, ``alpha_y``. Errors are
:class:`ParameterError`, one line naming the field as the user wrote it
(``material.alpha``), the value and what is accepted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping


class ParameterError(ValueError):
    """An invalid parameter value; the message is one line (field, value, what is accepted)."""


class ConfigError(ValueError):
    """Invalid run configuration; the message is one line naming field, value, and what is accepted."""


def fail(field_name: str, value: Any, accepted: str) -> None:
    """Raise the one-line :class:`ConfigError` ``field_name = value: accepted``."""
    raise ConfigError(f"{field_name} = {value!r}: {accepted}")


def _number(field_name: str, value: Any, accepted: str) -> float:
    """``value`` as a finite float, or a one-line error naming ``field_name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{field_name} = {value!r}: must be a number {accepted}")
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(f"{field_name} = {value!r}: must be a finite number {accepted}")
    return x


@dataclass(frozen=True)
class Number:
    """One scalar parameter.

    Attributes
    ----------
    key : str
        Config key (inside ``[material]``).
    summary : str
        What it is, a few words (``--help``).
    lo, hi : float or None
        Bounds; ``None`` for unbounded.
    lo_open, hi_open : bool
        Whether the bound itself is excluded.
    default : float or None
        Used when the key is omitted; ``None`` makes the key required.
    units : str
        ``"1"`` for dimensionless, else e.g. ``"rad"``.
    example : float
        A typical value, shown in ``--help``.
    reason : str
        Why a bound is there (appended to the out-of-range message), or empty.
    default_unless : str
        A key whose presence voids the default: when it is given and this key is not, the
        key is required (a conductor's ``k`` with ``eta``: gold's ``k`` with another metal's
        ``eta`` is no metal at all). Empty: the default always applies.
    """

    key: str
    summary: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    default: float | None = None
    units: str = "1"
    example: float = 1.0
    reason: str = ""  # why the range is bounded, appended to the out-of-range message
    default_unless: str = ""

    @property
    def keys(self) -> tuple[str, ...]:
        """The config keys this spec reads."""
        return (self.key,)

    @property
    def canonical_keys(self) -> tuple[str, ...]:
        """The keys of the canonical values it produces."""
        return (self.key,)

    def accepted(self) -> str:
        """The accepted range in words, e.g. ``"in [0, 1]"`` or ``"> 1.5"``."""
        if self.lo is not None and self.hi is not None:
            return (f"in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}"
                    f"{')' if self.hi_open else ']'}")
        if self.lo is not None:
            return f"{'>' if self.lo_open else '>='} {self.lo:g}"
        if self.hi is not None:
            return f"{'<' if self.hi_open else '<='} {self.hi:g}"
        return "(any finite number)"

    def _check(self, field_name: str, value: Any) -> float:
        x = _number(field_name, value, self.accepted())
        too_low = self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo))
        too_high = self.hi is not None and (x > self.hi or (self.hi_open and x == self.hi))
        if too_low and self.reason:  # the reason explains the upper bound: name the lower one
            raise ParameterError(f"{field_name} = {value!r}: must be {'>' if self.lo_open else '>='} {self.lo:g}")
        if too_low or too_high:
            why = f" ({self.reason})" if self.reason else ""
            raise ParameterError(f"{field_name} = {value!r}: must be {self.accepted()}{why}")
        return x

    def parse(self, raw: Mapping[str, Any], table: str, owner: str) -> dict[str, float]:
        """Canonical ``{key: value}`` from the user's table ``raw``.

        Parameters
        ----------
        raw : mapping
            The user's ``[material]`` table (only this spec's keys are read).
        table : str
            Name of the table for messages (``"material"``).
        owner : str
            What needs the parameter, for messages (``"distribution 'ggx'"``).
        """
        if self.key not in raw:
            if self.default is None:
                raise ParameterError(f"{table}.{self.key} is missing: {owner} needs {self.key} "
                                     f"({self.summary}, {self.accepted()})")
            return {self.key: float(self.default)}
        return {self.key: self._check(f"{table}.{self.key}", raw[self.key])}

    def is_isotropic(self, values: Mapping[str, float]) -> bool:
        """A scalar parameter never breaks rotational symmetry."""
        return True

    def check_together(self, raw: Mapping[str, Any], table: str, owner: str) -> None:
        """One-line :class:`ParameterError` when ``default_unless`` is given and this key is not
        (run after every key's own value is checked, so a bad value is named first)."""
        other = self.default_unless
        if other and self.key not in raw and other in raw:
            raise ParameterError(f"{table}.{self.key} is missing: {owner} needs {self.key} ({self.accepted()}) "
                                 f"with {table}.{other} = {raw[other]!r}; the default {self.key} = "
                                 f"{self.default:g} holds only when {other} is not given either")

    def help(self) -> str:
        """One ``--help`` line: ``key = example (summary; range[, default])``."""
        default = "required" if self.default is None else f"default {self.default:g}"
        if self.default_unless and self.default is not None:
            default += f", required with {self.default_unless}"
        units = "" if self.units == "1" else f" {self.units}"
        return f"{self.key} = {self.example:g}{units}  ({self.summary}; {self.accepted()}; {default})"


@dataclass(frozen=True)
class Roughness:
    """Stretched roughness: ``alpha`` (isotropic) or both ``alpha_x`` and ``alpha_y``.

    Canonical values are ``alpha_x`` (along +x) and ``alpha_y`` (along +y), both > 0
    (physics.md sec. 2: anisotropy by stretching the slopes, H sec. 5).
    """

    summary: str = "roughness (slope scale)"
    example: float = 0.5

    keys = ("alpha", "alpha_x", "alpha_y")
    canonical_keys = ("alpha_x", "alpha_y")

    @staticmethod
    def accepted() -> str:
        """The accepted range in words."""
        return "> 0"

    def parse(self, raw: Mapping[str, Any], table: str, owner: str) -> dict[str, float]:
        """Canonical ``{"alpha_x": ..., "alpha_y": ...}``; see :meth:`Number.parse`."""
        def positive(key):
            x = _number(f"{table}.{key}", raw[key], "> 0")
            if not x > 0.0:
                raise ParameterError(f"{table}.{key} = {raw[key]!r}: must be > 0")
            return x

        if "alpha" in raw:
            for key in ("alpha_x", "alpha_y"):
                if key in raw:
                    raise ParameterError(f"{table}.{key} = {raw[key]!r}: give either alpha (isotropic) "
                                         "or alpha_x and alpha_y, not both")
            alpha = positive("alpha")
            return {"alpha_x": alpha, "alpha_y": alpha}
        if "alpha_x" in raw or "alpha_y" in raw:
            for key in ("alpha_x", "alpha_y"):
                if key not in raw:
                    raise ParameterError(f"{table}.{key} is missing: anisotropic roughness needs both "
                                         "alpha_x and alpha_y (> 0)")
            return {"alpha_x": positive("alpha_x"), "alpha_y": positive("alpha_y")}
        raise ParameterError(f"{table}.alpha is missing: {owner} needs alpha (> 0) or alpha_x and alpha_y")

    @staticmethod
    def is_isotropic(values: Mapping[str, float]) -> bool:
        """True when ``alpha_x == alpha_y``."""
        return values["alpha_x"] == values["alpha_y"]

    def help(self) -> str:
        """One ``--help`` line."""
        return (f"alpha = {self.example:g}  ({self.summary}; > 0; required), or alpha_x, alpha_y "
                "(anisotropic: along +x and +y)")


def parse_parameters(specs, raw: Mapping[str, Any], table: str, owner: str) -> dict[str, float]:
    """Canonical values of every spec in ``specs`` from the user's table ``raw``.

    Keys of ``raw`` that no spec reads are the caller's business (see
    :func:`accepted_keys`).
    """
    values: dict[str, float] = {}
    for spec in specs:
        values.update(spec.parse(raw, table, owner))
    for spec in specs:  # the rules between keys, once each key's own value is valid
        if hasattr(spec, "check_together"):
            spec.check_together(raw, table, owner)
    return values


def accepted_keys(specs) -> tuple[str, ...]:
    """Every config key the specs read, in declaration order."""
    return tuple(key for spec in specs for key in spec.keys)


def canonical_keys(specs) -> tuple[str, ...]:
    """Every canonical value key the specs produce, in declaration order."""
    return tuple(key for spec in specs for key in spec.canonical_keys)


__all__ = ["ConfigError", "Number", "Roughness", "ParameterError", "accepted_keys", "canonical_keys", "fail",
           "parse_parameters"]
