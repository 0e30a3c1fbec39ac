"""The two sides of ``vcavity plot --kind versus``: two tables, or two points of a sweep file.

A :class:`Side` holds what the comparison reads of one material's tabulation: the
incident directions, the orders, ``brdf`` and ``brdf_stderr`` per cell, the albedo and
the paths per direction, the sensor. It has the attributes of a
:class:`~vcavity.io.table.Table` that :func:`vcavity.plots.data.slice_data` reads, so a
sweep's point is sliced by the same code as a table.

A sweep point is chosen as the user writes it: ``--point alpha=0.5`` fixes point axes,
``--versus microsurface`` (or ``--versus alpha=0.1,1.0``) names the axis whose two
values are compared (:func:`sweep_sides`). Every refusal is a one-line
:class:`~vcavity.plots.request.PlotError`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vcavity.plots.request import PlotError
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sweep.albedo import stderr_of

INCIDENCE_AXES = ("theta_i_deg", "phi_i_deg")
#: The axis compared when a sweep has it and ``--versus`` is not given.
DEFAULT_VERSUS_AXIS = "microsurface"


@dataclass(frozen=True, eq=False)
class Side:
    """One material's tabulation, from a table or a sweep point (module docstring).

    Attributes
    ----------
    label : str
        How the figure names it (``"v-cavity (a.h5)"``, ``"microsurface = smith"``).
    path : pathlib.Path
        The file it was read from.
    material : dict
        Its material as a table stores it (``/material``; a sweep point: the shared
        material with the point's axis values).
    estimator : str
    theta_i, phi_i, theta_i_deg, phi_i_deg : ndarray (n_i,)
    order : ndarray of int64 (n_k,)
    brdf, brdf_stderr : ndarray (n_i, n_k, n_c)
    albedo : ndarray (n_i, n_k)
    paths : ndarray (n_i,)
    sensor : EqualAreaSensor
    compared : tuple of str
        Material keys the sweep axis compared sets (they differ by design); empty for a table.
    deterministic : bool
        A deterministic model's tabulation (estimator exact): ``brdf_stderr`` is the
        model's own error estimate, not a statistical error.
    """

    label: str
    path: Path
    material: dict
    estimator: str
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    order: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray
    albedo: np.ndarray
    paths: np.ndarray
    sensor: EqualAreaSensor
    compared: tuple = ()
    deterministic: bool = False

    @property
    def theta_i(self) -> np.ndarray:
        """Incident polar angles, rad."""
        return np.radians(self.theta_i_deg)

    @property
    def phi_i(self) -> np.ndarray:
        """Incident azimuths, rad."""
        return np.radians(self.phi_i_deg)

    def order_index(self, k: int) -> int:
        """Position of order ``k`` (0 = f_inf) on the order axis (ValueError if absent)."""
        hits = np.flatnonzero(self.order == int(k))
        if hits.size == 0:
            raise ValueError(f"order {k} is not in {self.label}")
        return int(hits[0])

    def albedo_stderr(self, k: int) -> np.ndarray | None:
        """Standard error of the albedo of order ``k`` per direction, None where the
        estimator gives none (:func:`vcavity.sweep.albedo.stderr_of`: binomial in the paths)."""
        f1 = self.albedo[:, self.order_index(1)] if 1 in self.order else None
        return stderr_of(self.estimator, k, self.albedo[:, self.order_index(k)], f1, self.paths)


def _value(v) -> str:
    return f"{v:g}" if isinstance(v, (int, float)) else str(v)


def differences_text(differs: dict) -> str:
    """``alpha_x 0.5 vs 0.6, kd 0.9 vs 0.8`` of ``{key: (A's, B's)}`` (a missing value: ``(none)``)."""
    def text(v):
        return "(none)" if v is None else _value(v)

    return ", ".join(f"{k} {text(a)} vs {text(b)}" for k, (a, b) in differs.items())


def table_side(table) -> Side:
    """A :class:`Side` of a :class:`~vcavity.io.table.Table` (labelled by its microsurface and file)."""
    surface = table.material.get("microsurface", "v-cavity")
    return Side(label=f"{surface} ({table.path.name})", path=table.path, material=dict(table.material),
                estimator=table.estimator, theta_i_deg=np.asarray(table.theta_i_deg, np.float64),
                phi_i_deg=np.asarray(table.phi_i_deg, np.float64), order=np.asarray(table.order, np.int64),
                brdf=np.asarray(table.brdf), brdf_stderr=np.asarray(table.brdf_stderr),
                albedo=np.asarray(table.albedo), paths=np.asarray(table.paths, np.float64), sensor=table.sensor,
                deterministic=bool(table.deterministic))


def _position(axis, text: str, option: str, name: str) -> int:
    """Position on ``axis`` of the value written ``text`` (numbers within 1e-9, names exactly)."""
    listed = ", ".join(_value(v) for v in axis.values)
    for j, v in enumerate(axis.values):
        if isinstance(v, str):
            if v == text.strip():
                return j
            continue
        try:
            if abs(float(text) - float(v)) <= 1e-9 * max(1.0, abs(float(v))):
                return j
        except ValueError:
            break
    raise PlotError(f"{option} = {text.strip()!r}: not a value of axis {axis.name} of sweep {name} "
                    f"(values: {listed})")


def _assignment(text: str, option: str, sweep, name: str):
    """``KEY=VALUE`` of ``--point`` / ``--versus``: the point axis and the value's text."""
    key, sep, value = str(text).partition("=")
    key = key.strip()
    axes = {a.name: a for a in sweep.axes}
    point_axes = ", ".join(sweep.point_axes)
    if key in INCIDENCE_AXES:
        raise PlotError(f"{option} = {text!r}: {key} is an incident direction, drawn with --theta-i; "
                        f"{option} takes a point axis of sweep {name} ({point_axes})")
    if key not in axes or key not in sweep.point_axes:
        raise PlotError(f"{option} = {text!r}: not a point axis of sweep {name} (point axes: {point_axes})")
    return axes[key], (value if sep else None)


def sweep_sides(sweep, points=(), versus=None) -> tuple[Side, Side]:
    """The two points of ``sweep`` that ``--point`` and ``--versus`` name.

    Parameters
    ----------
    sweep : vcavity.io.sweep_table.SweepData
    points : sequence of str
        ``KEY=VALUE``: a value of each point axis that has more than one (but the compared one).
    versus : str, optional
        ``AXIS`` (an axis of exactly two values) or ``AXIS=A,B``: the axis whose values A and B
        are compared. Default :data:`DEFAULT_VERSUS_AXIS` when the sweep has it.

    Raises
    ------
    PlotError
        One line naming the option, the value and what is accepted; also a point not done.
    """
    name = sweep.path.name if sweep.path is not None else "(in memory)"
    if versus is None:
        if DEFAULT_VERSUS_AXIS not in sweep.point_axes:
            raise PlotError(f"--versus is needed: sweep {name} has no {DEFAULT_VERSUS_AXIS} axis; name the axis "
                            f"to compare, e.g. --versus AXIS=A,B (point axes: {', '.join(sweep.point_axes)})")
        versus = DEFAULT_VERSUS_AXIS
    axis, values = _assignment(versus, "--versus", sweep, name)
    if values is None:
        if len(axis.values) != 2:
            raise PlotError(f"--versus = {versus!r}: axis {axis.name} has {len(axis.values)} values "
                            f"({', '.join(_value(v) for v in axis.values)}); name two: --versus {axis.name}=A,B")
        compared = [0, 1]
    else:
        parts = values.split(",")
        if len(parts) != 2:
            raise PlotError(f"--versus = {versus!r}: expected two values of {axis.name}, AXIS=A,B")
        compared = [_position(axis, part, "--versus", name) for part in parts]
        if compared[0] == compared[1]:
            raise PlotError(f"--versus = {versus!r}: the two values are the same point")
    fixed = {}
    for text in points or ():
        other, value = _assignment(text, "--point", sweep, name)
        if value is None:
            raise PlotError(f"--point = {text!r}: expected AXIS=VALUE")
        if other.name == axis.name:
            raise PlotError(f"--point = {text!r}: {axis.name} is the compared axis (--versus)")
        fixed[other.name] = _position(other, value, "--point", name)
    for other in sweep.axes:
        if other.name in sweep.point_axes and other.name != axis.name and other.name not in fixed:
            if len(other.values) > 1:
                raise PlotError(f"--point is needed for axis {other.name} of sweep {name}: it has "
                                f"{len(other.values)} values ({', '.join(_value(v) for v in other.values)}); "
                                f"choose one, e.g. --point {other.name}={_value(other.values[0])}")
            fixed[other.name] = 0
    return tuple(_point_side(sweep, {**fixed, axis.name: j}, axis.name, name) for j in compared)


def _point_side(sweep, where: dict, compared: str, name: str) -> Side:
    """The :class:`Side` of the sweep point at ``where`` (point axis -> position)."""
    point = tuple(where[a] for a in sweep.point_axes)
    axes = {a.name: a for a in sweep.axes}
    text = " ".join(f"{a}={_value(axes[a].values[where[a]])}" for a in sweep.point_axes)
    if not int(np.asarray(sweep.data["done"])[point]):
        raise PlotError(f"point {text} of sweep {name} is not done (vcavity sweep ... --resume runs it)")
    material = dict(sweep.material)
    for a in sweep.point_axes:
        axis = axes[a]
        if axis.paired:
            material.update({key: values[where[a]] for key, values, *_ in axis.paired})
        else:
            material[a] = axis.values[where[a]]
    # the directions of the point, theta-major, as the point's run has them
    incidence = [a for a in sweep.axes if a.name in INCIDENCE_AXES]
    theta, phi, indices = [], [], []
    for positions in itertools.product(*(range(len(a.values)) for a in incidence)):
        chosen = dict(zip((a.name for a in incidence), positions))
        values = {a.name: float(a.values[chosen[a.name]]) for a in incidence}
        theta.append(values["theta_i_deg"])
        phi.append(values.get("phi_i_deg", float(sweep.scalars.get("phi_i_deg", 0.0))))
        indices.append(tuple(where.get(a.name, chosen.get(a.name)) for a in sweep.axes))
    order = np.lexsort((phi, theta))  # by theta, then phi, whichever incidence axis the file has first
    theta, phi, indices = [theta[i] for i in order], [phi[i] for i in order], [indices[i] for i in order]
    data = sweep.data
    return Side(label=f"{compared} = {_value(axes[compared].values[where[compared]])}", path=sweep.path,
                material=material, estimator=str(sweep.attrs.get("estimator", "analog")),
                theta_i_deg=np.array(theta), phi_i_deg=np.array(phi), order=np.asarray(sweep.order, np.int64),
                brdf=np.stack([data["brdf"][i] for i in indices]),
                brdf_stderr=np.stack([data["brdf_stderr"][i] for i in indices]),
                albedo=np.stack([data["albedo"][i] for i in indices]),
                paths=np.array([data["paths"][i] for i in indices], dtype=np.float64),
                sensor=EqualAreaSensor(int(sweep.attrs["sensor_resolution"])),
                compared=tuple(key for key, *_ in axes[compared].paired) or (compared,),
                deterministic=bool(sweep.attrs.get("deterministic", 0)))


__all__ = ["DEFAULT_VERSUS_AXIS", "Side", "differences_text", "sweep_sides", "table_side"]
