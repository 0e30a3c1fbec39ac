"""Parameter sweeps: a grid of runs from one TOML file (docs/sweeps.md).

A sweep file is a run config (``[material]``, ``[incidence]``, ``[simulation]``,
``[output]``: the base) plus a ``[sweep]`` table whose keys are grid axes with lists of
values::

    [sweep]
    alpha = [0.1, 0.3, 0.6, 1.0]     # any parameter of the distribution or facet model
    eta = [1.0, 1.5]                 # (alpha_x and alpha_y are two separate axes)
    theta_i_deg = [0, 45, 70]        # and distribution, phi_i_deg

The grid is the Cartesian product; a value in ``[sweep]`` replaces the base's value of
that key. A *paired* axis (``[sweep.paired.NAME]``, :mod:`vcavity.sweep.paired`) is one
axis whose points set several keys together (a metal's ``eta`` and ``k`` per wavelength). A *point* is one material: a position on every axis except ``theta_i_deg`` and
``phi_i_deg``, which are the incident directions of the point's run. Every point's
config is validated before anything is traced (one-line :class:`SweepError` naming the
field as written: ``sweep.alpha[2] = -1: must be > 0``).

Seeds: a point's run has the seed :func:`point_seed` (a hash of the sweep seed,
``simulation.seed``, and the point's canonical material), and its directions are keyed by
their angles as in any run (:func:`vcavity.rng.direction_key`), so adding, removing or
reordering axis values never changes the other points' counts, and a point's counts
equal those of a plain run of its config.

Running and resuming are in :mod:`vcavity.sweep.run`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vcavity import config as config_mod
from vcavity.config import ConfigError, RunConfig
from vcavity.estimators import registry as estimators
from vcavity.facet import registry as facets
from vcavity.io.sweep_table import GridAxis, SweepData
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sweep.axes import (PointAxis, axis_keys, grid_axis, grid_names, material_keys, paired_grid_axis, parse_paired,
                                plain_axis, point_axes, setter_field)

#: Most grid positions (points x directions) of one sweep: validation stays within seconds.
MAX_GRID_POINTS = 100_000
_ROUGHNESS = ("alpha", "alpha_x", "alpha_y")
_SEED_TAG = "vcavity-sweep-point-v1"


class SweepError(ConfigError):
    """Invalid sweep file; one line naming the field as written, the value, what is accepted."""


def point_seed(sweep_seed: int, material) -> int:
    """Seed of a point's run: the first 8 bytes, little-endian, of SHA-256 of
    ``"vcavity-sweep-point-v1\\n" + JSON({"seed": sweep_seed, "material": material.to_dict()})``
    (keys sorted, floats as Python's shortest round-trip repr, -0.0 as 0.0).

    The canonical material (``alpha`` stored as ``alpha_x``, ``alpha_y``) is hashed, not
    the point's position, so a point keeps its counts whatever else the grid holds.
    """
    values = {k: (v + 0.0 if isinstance(v, float) else v) for k, v in material.to_dict().items()}
    text = json.dumps({"seed": int(sweep_seed), "material": values}, sort_keys=True)
    digest = hashlib.sha256((_SEED_TAG + "\n" + text).encode()).digest()
    return int.from_bytes(digest[:8], "little")


@dataclass(frozen=True)
class Point:
    """One material of the grid: its position on the point axes and its validated run
    (every incident direction of the grid, theta-major; seed :func:`point_seed`)."""

    index: tuple[int, ...]
    config: RunConfig


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: grid axes (file order), points, seeds and the spec's digest."""

    axes: tuple[GridAxis, ...]
    point_axes: tuple[str, ...]
    points: tuple[Point, ...]
    seed: int
    digest: str
    spec: dict
    source: str
    output: Path | None
    n_phi: int
    scalars: dict
    overrides: dict = dataclasses.field(default_factory=dict)

    @property
    def n_directions(self) -> int:
        """Incident directions of every point."""
        return len(self.points[0].config.incidence)

    def grid_index(self, point: Point, direction: int) -> tuple[int, ...]:
        """Position on the grid axes of direction ``direction`` of ``point``."""
        where = dict(zip(self.point_axes, point.index))
        where["theta_i_deg"], where["phi_i_deg"] = divmod(direction, self.n_phi)
        return tuple(where[a.name] for a in self.axes)

    def point_paths(self, point: Point) -> int:
        """Paths planned for a point (with a target error: the caps)."""
        return sum(point.config.path_budget(d) for d in point.config.incidence)

    def new_data(self) -> SweepData:
        """The in-memory sweep file before any point is run (seeds filled in)."""
        first = self.points[0].config
        sensor = EqualAreaSensor(first.sensor_resolution)
        cells = {"theta_o": sensor.cell_theta, "phi_o": sensor.cell_phi, "cell_center": sensor.cell_center,
                 "cell_solid_angle": sensor.cell_solid_angle,
                 "cell_projected_solid_angle": sensor.cell_projected_solid_angle}
        attrs = {"seed": np.uint64(self.seed), "spec": json.dumps(self.spec, sort_keys=True, default=str),
                 "spec_digest": self.digest, "source": self.source, "estimator": first.estimator,
                 "deterministic": np.int64(estimators.get(first.estimator).walk(first.material) is None),
                 "block_size": np.int64(BLOCK_SIZE), "max_bounces": np.int64(first.effective_max_bounces),
                 "max_order": np.int64(first.max_order), "track_all_orders": np.int8(first.track_all_orders),
                 "sensor_partition": sensor.partition, "sensor_resolution": np.int64(sensor.resolution),
                 "n_cells": np.int64(sensor.n_cells),
                 "target_error": float("nan") if first.target_error is None else float(first.target_error),
                 "overrides": overrides_text(self.overrides),
                 # where its walks run (simulation.device, the same at every point: part of their configs)
                 "device": "cpu" if estimators.get(first.estimator).walk(first.material) is None else first.device}
        data = SweepData(axes=self.axes, point_axes=self.point_axes, order=np.array(first.orders, np.int64),
                         cells=cells, attrs=attrs, material=_shared_material(self.points),
                         scalars=dict(self.scalars))
        data.allocate()
        for point in self.points:
            data.data["seed"][point.index] = point.config.seed
        return data


def _shared_material(points) -> dict:
    """Canonical material values that are the same at every point (stored in /material)."""
    shared = dict(points[0].config.material.to_dict())
    for point in points[1:]:
        values = point.config.material.to_dict()
        shared = {k: v for k, v in shared.items() if k in values and values[k] == v}
    return shared


def _fail(field: str, value: Any, accepted: str):
    raise SweepError(f"{field} = {value!r}: {accepted}")


def _structure(raw: dict) -> tuple[dict, dict, tuple[PointAxis, ...]]:
    """``(base, axes, paired)``: the run tables, the plain ``[sweep]`` lists and the paired
    axes, structurally checked."""
    if not isinstance(raw, dict):
        _fail("sweep file", raw, "must be a TOML document")
    if "sweep" not in raw:
        raise SweepError("sweep is missing: a sweep file needs a [sweep] table of axes with lists of "
                         "values, e.g. alpha = [0.1, 0.5] (a plain run config runs with vcavity run)")
    table = raw["sweep"]
    accepted = ", ".join(axis_keys() + ("paired",))
    if not isinstance(table, dict) or not table:
        _fail("sweep", table, f"must be a table with at least one axis; accepted axes: {accepted}")
    table = {key: values for key, values in table.items() if key != "paired"}
    for key, values in table.items():
        if key not in axis_keys():
            _fail(f"sweep.{key}", values, f"not a sweep axis; accepted: {accepted}")
        if not isinstance(values, list) or not values:
            _fail(f"sweep.{key}", values, f"must be a non-empty list of values, e.g. {key} = [a, b]")
        for i, value in enumerate(values):
            if isinstance(value, (list, dict)):
                _fail(f"sweep.{key}[{i}]", value, "must be a single value")
    paired = ()
    if "paired" in raw["sweep"]:
        try:
            paired = parse_paired(raw["sweep"]["paired"], ("microsurface", "distribution") + material_keys(),
                                  tuple(table))
        except ValueError as exc:
            raise SweepError(str(exc)) from None
    every_axis = [*(plain_axis(k, v) for k, v in table.items()), *paired]
    swept = {key: (setter_field(axis, key), list(values)) for axis in every_axis for key, values in axis.settings}
    if "alpha" in swept:
        for key in ("alpha_x", "alpha_y"):
            if key in swept:
                _fail(*swept[key], "give either alpha (isotropic) or alpha_x and alpha_y, not both")
    base = {key: value for key, value in raw.items() if key != "sweep"}
    for name in ("material", "incidence"):
        if not isinstance(base.get(name, {}), dict):
            _fail(name, base[name], "must be a TOML table")
    return base, table, paired


def _applicability(swept: tuple[PointAxis, ...], material: dict) -> None:
    """Every swept parameter must be a parameter of every distribution (and the facet) in play."""
    setters = {key: axis for axis in swept for key in axis.keys}
    dist_axis = setters.get("distribution")
    names = [dist_axis.values_at(j)["distribution"] for j in range(len(dist_axis))] if dist_axis else \
        [material.get("distribution", "beckmann")]
    if dist_axis:
        for j, name in enumerate(names):
            if name not in distributions.NAMES:
                _fail(f"{setter_field(dist_axis, 'distribution')}[{j}]", name,
                      f"accepted: {', '.join(distributions.NAMES)}")
    facet = material.get("facet", "interfaced_lambertian")
    dist_keys = {k for n in distributions.NAMES for k in distributions.config_keys(n)}
    for key, axis in setters.items():
        field, values = setter_field(axis, key), dict(axis.settings)[key]
        if key in dist_keys:
            for j, name in enumerate(names):
                if name in distributions.NAMES and key not in distributions.config_keys(name):
                    where = f" ({setter_field(dist_axis, 'distribution')}[{j}])" if dist_axis else ""
                    _fail(field, list(values), f"not a parameter of distribution {name!r}{where} "
                          f"(it takes: {', '.join(distributions.config_keys(name)) or 'nothing'})")
        elif key not in ("distribution", "microsurface") and facet in facets.NAMES \
                and key not in facets.config_keys(facet):
            _fail(field, list(values), f"not used by facet {facet!r} "
                  f"(it takes: {', '.join(facets.config_keys(facet)) or 'nothing'})")


def _one_value(incidence: dict, key: str) -> Any:
    """A base incidence value a sweep needs single (paths, an azimuth that is not swept)."""
    value = incidence.get(key)
    if isinstance(value, list):
        if len(value) != 1:
            hint = "sweep azimuths with [sweep] phi_i_deg" if key == "phi_i_deg" else \
                "every direction of every point gets the same number"
            _fail(f"incidence.{key}", value, f"a sweep takes one value here ({hint})")
        return value[0]
    return value


def _check_directions(field: str, key: str, values: list, phi, paths, indexed: bool = True) -> None:
    """Validate each incident angle (or the paths) alone, naming ``field[i]`` (``indexed``)."""
    material = config_mod.DEFAULT_RAW["material"]
    for i, value in enumerate(values):
        incidence = {"theta_i_deg": [0.0], "phi_i_deg": 0.0, "paths": paths}
        incidence[key] = [value] if key == "theta_i_deg" else value
        if key == "theta_i_deg" and phi is not None:
            incidence["phi_i_deg"] = phi
        try:
            config_mod.validate({"material": material, "incidence": incidence})
        except ConfigError as exc:
            message = str(exc)
            name = message.split(" ", 1)[0]
            if name != f"incidence.{key}":
                raise SweepError(message) from None
            raise SweepError(field + (f"[{i}]" if indexed else "") + message[len(name):]) from None


def _check_distinct(field: str, values: list) -> None:
    seen = {}
    for i, value in enumerate(values):
        canonical = value if isinstance(value, str) else float(value)
        if canonical in seen:
            _fail(f"{field}[{i}]", value, f"repeats {field}[{seen[canonical]}]; the values of an axis must differ")
        seen[canonical] = i


def overrides_text(overrides: dict) -> str:
    """How a sweep file records the overrides of its sweep file: JSON ``{field: value}``,
    keys sorted (``{}``: none)."""
    return json.dumps(overrides, sort_keys=True)


def _override(raw: dict, overrides: dict) -> dict:
    """``raw`` with each ``"table.key": value`` of ``overrides`` set (a copy; a table that is
    not a TOML table is left for :func:`_structure` to refuse)."""
    raw = dict(raw)
    for field, value in overrides.items():
        table, key = field.split(".")
        section = raw.get(table, {})
        if isinstance(section, dict):
            raw[table] = {**section, key: value}
    return raw


def parse(raw: dict, source: str = "<dict>", base_dir: Path | None = None,
          overrides: dict | None = None) -> Sweep:
    """Validate a parsed sweep file: every point's config, before anything runs.

    Parameters
    ----------
    raw : dict
        The parsed TOML.
    source : str
        Where it came from (for messages and the file's ``source``).
    base_dir : pathlib.Path, optional
        Folder that relative paths in it are relative to.
    overrides : dict, optional
        ``{"incidence.paths": 20000, "simulation.seed": 3, ...}``: values that replace the
        base's at every point (``vcavity sweep --paths``, ...); recorded in the sweep file
        (attribute ``overrides``) and part of the sweep's digest through the configs.

    Raises
    ------
    SweepError
        One line naming the field as written (``sweep.alpha[2]``, ``material.kd``), the
        value and what is accepted.
    """
    overrides = dict(overrides or {})
    raw = _override(raw, overrides)
    base, table, paired = _structure(raw)
    written = raw["sweep"]
    swept = point_axes(written, table, paired)
    material = dict(base.get("material", {}))
    for axis in swept:  # a swept roughness replaces the base's roughness keys
        for key in axis.keys:
            if key in _ROUGHNESS:
                for other in (("alpha_x", "alpha_y") if key == "alpha" else ("alpha",)):
                    material.pop(other, None)
    _applicability(swept, material)
    incidence = dict(base.get("incidence", {}))
    paths = _one_value(incidence, "paths")
    paths = config_mod.DEFAULT_PATHS if paths is None else paths
    thetasetter_field = "sweep.theta_i_deg" if "theta_i_deg" in table else "incidence.theta_i_deg"
    thetas = table.get("theta_i_deg", incidence.get("theta_i_deg", [0.0]))
    theta_listed = isinstance(thetas, list)
    thetas = thetas if theta_listed else [thetas]
    phi_listed = "phi_i_deg" in table
    phis = table["phi_i_deg"] if phi_listed else [_one_value(incidence, "phi_i_deg") or 0.0]
    n_grid = math.prod(len(a) for a in swept) * len(thetas) * len(phis)
    if n_grid > MAX_GRID_POINTS:
        sizes = " x ".join(str(n) for n in [*(len(a) for a in swept), len(thetas), len(phis)])
        _fail("sweep", f"{sizes} grid", f"{n_grid:,} grid positions; at most {MAX_GRID_POINTS:,} per sweep file")
    _check_directions("incidence.paths", "paths", [paths], None, paths, indexed=False)
    _check_directions("sweep.phi_i_deg" if phi_listed else "incidence.phi_i_deg", "phi_i_deg", phis, None, paths,
                      indexed=phi_listed)
    _check_directions(thetasetter_field, "theta_i_deg", thetas, phis[0], paths, indexed=theta_listed)
    directions = {"theta_i_deg": [t for t in thetas for _ in phis], "phi_i_deg": [p for _ in thetas for p in phis],
                  "paths": paths}
    points, digest, base_cfg = [], hashlib.sha256(), None
    for index in itertools.product(*(range(len(a)) for a in swept)):
        values = {key: value for a, i in zip(swept, index) for key, value in a.values_at(i).items()}
        try:
            cfg = config_mod.validate({**base, "material": {**material, **values},
                                       "incidence": {**incidence, **directions}},
                                      source=source, base_dir=base_dir)
        except ConfigError as exc:
            raise _at_point(str(exc), swept, index) from None
        base_cfg = base_cfg or cfg  # the sweep's seed and output: the base's, the same at every point
        cfg = dataclasses.replace(cfg, seed=point_seed(cfg.seed, cfg.material), output=None)
        defining = {k: v for k, v in cfg.to_dict().items() if k not in ("output", "source")}
        digest.update(json.dumps(defining, sort_keys=True, default=str).encode())
        points.append(Point(index=index, config=cfg))
    for axis in swept:
        _check_distinct(setter_field(axis, axis.label_key or axis.name), list(axis.labels))
    _check_distinct(thetasetter_field, thetas)
    if "phi_i_deg" in table:
        _check_distinct("sweep.phi_i_deg", phis)
    by_name = {a.name: a for a in paired}
    values_of = {**table, "theta_i_deg": thetas, "phi_i_deg": phis}
    axes = tuple(paired_grid_axis(by_name[k], material) if k in by_name else grid_axis(k, values_of[k], material)
                 for k in grid_names(written, paired))
    # a paired axis adds what it sets; the plain axes keep the form older files were hashed with
    axis_spec = [[a.name, list(a.values)] + ([{key: list(v) for key, v, *_ in a.paired}] if a.paired else [])
                 for a in axes]
    digest.update(json.dumps({"axes": axis_spec, "seed": base_cfg.seed}, sort_keys=True, default=str).encode())
    spec = {"base": {k: v for k, v in base.items() if k != "output"}, "sweep": written, "axes": axis_spec}
    scalars = {} if "phi_i_deg" in table else {"phi_i_deg": float(phis[0])}
    return Sweep(axes=axes, point_axes=tuple(a.name for a in swept), points=tuple(points), seed=base_cfg.seed,
                 digest=digest.hexdigest(), spec=spec, source=source, output=base_cfg.output,
                 n_phi=len(phis), scalars=scalars, overrides=overrides)


def _at_point(message: str, swept: tuple[PointAxis, ...], index) -> SweepError:
    """A point's config error, naming the ``[sweep]`` list it came from."""
    name = message.split(" ", 1)[0]
    for axis, i in zip(swept, index):
        for key in axis.keys:
            if name == f"material.{key}":
                return SweepError(f"{setter_field(axis, key)}[{i}]" + message[len(name):])
    if swept and any(index):
        where = ", ".join(f"{setter_field(a, a.label_key or a.name)}[{i}] = {a.labels[i]!r}"
                          for a, i in zip(swept, index))
        return SweepError(f"{message} (at the sweep point {where})")
    return SweepError(message)


def load(path: str | Path, overrides: dict | None = None) -> Sweep:
    """Read and validate a sweep file (TOML), with ``overrides`` as in :func:`parse`.

    Raises
    ------
    SweepError
        Unreadable file, TOML syntax error, or invalid content (one line).
    """
    from vcavity.config import read_toml_text

    path = Path(path)
    try:
        raw = tomllib.loads(read_toml_text(path, "sweep file"))
    except ValueError as exc:
        if not isinstance(exc, tomllib.TOMLDecodeError):
            raise SweepError(str(exc)) from None
        raise SweepError(f"sweep file {str(path)!r}: invalid TOML: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"sweep file {str(path)!r}: invalid TOML: {exc}") from None
    return parse(raw, source=str(path), base_dir=path.parent, overrides=overrides)


__all__ = ["MAX_GRID_POINTS", "Point", "Sweep", "SweepError", "axis_keys", "load", "parse", "point_seed"]
