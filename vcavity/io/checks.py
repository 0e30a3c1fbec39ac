"""Checks of what a table or sweep file holds, made when it is read (plain NumPy).

A file edited by hand or damaged on the way (NaN or negated ``brdf``, a scaled
``albedo``, zeroed solid angles, repeated orders, fractional counts, an unknown estimator,
a sweep's ``done`` flag out of range) must not be read as a table: every consumer
(``info``, ``compare``, ``plot``, ``export``, ``sweep --resume``, the table API) would
report or export nonsense. :func:`vcavity.io.table.open_table` and
:func:`vcavity.io.sweep_table.open_sweep` refuse such a file with a one-line
:class:`TableFormatError` naming the dataset; the checks below are the ones that are cheap
(one pass over each array, no model, no simulation), and they only refuse values that no
writer of vcavity produces (writer.py and estimators.py).
"""

from __future__ import annotations

import numpy as np

from vcavity.estimators import ESTIMATORS, EXACT, order_source
from vcavity.sensor.grid import EqualAreaSensor

#: Rounding allowance of ``albedo`` against ``Σ_c brdf Ω⊥_c``. The writers compute both from
#: the same numbers (analog: ``exits / N`` and ``counts / (N Ω⊥)``; exact-f1: ``Σ I_c`` and
#: ``I_c / Ω⊥_c``, mirror pairs merged; paper: ``Σ q / (Q N)`` and ``Σ q / (Q N Ω⊥)``;
#: exact: the sum itself), so they differ by the rounding of a sum of ``n_c`` non-negative
#: terms, at most about ``n_c`` ulp: 2e-10 relative for a 1000 x 1000 sensor. A real
#: defect (an order scaled, a cell lost) is many orders of magnitude larger.
ALBEDO_RTOL = 1e-9
#: Sensor geometry and angles are written from the same formulas the reader rebuilds them
#: with; the writer accepts degrees that match the radians to 1e-12 (writer._degrees).
GEOMETRY_RTOL = 1e-12
GEOMETRY_ATOL = 1e-12
#: Flag datasets and the values they may take (schema.FLAGS; sweeps add ``done``).
FLAG_VALUES = {"order_source": (0, 1, 2), "folded": (0, 1), "target_reached": (-1, 0, 1), "done": (0, 1)}


class TableFormatError(ValueError):
    """A file is not a readable vcavity table or sweep (wrong kind, version or content).

    The message is one line and names the file and, for bad content, the dataset.
    """


def _where(index) -> str:
    return f" at index {index}" if index is not None else ""


def _first_bad(bad: np.ndarray, array: np.ndarray):
    """Index (tuple, or int for 1-D) and value of the first True of ``bad``, or None."""
    hits = np.flatnonzero(bad.ravel())
    if hits.size == 0:
        return None
    index = np.unravel_index(hits[0], array.shape)
    value = array[index].item()
    return (int(index[0]) if array.ndim == 1 else tuple(int(i) for i in index)), value


def refuse(name: str, index, value, location, accepted: str):
    """Raise the one-line :class:`TableFormatError` of a bad value of dataset ``name``."""
    raise TableFormatError(f"dataset '{name}' = {value!r}{_where(index)} in {location}: {accepted}")


def check_integer(name: str, array: np.ndarray, location) -> None:
    """``array`` must be stored as integers (counts and path numbers are never fractional)."""
    if not np.issubdtype(array.dtype, np.integer):
        raise TableFormatError(f"dataset '{name}' has dtype {array.dtype} in {location}: must hold integers")


def check_numeric(name: str, array: np.ndarray, location) -> None:
    """``array`` must be stored as numbers (not strings or compound records)."""
    if not np.issubdtype(array.dtype, np.number):
        raise TableFormatError(f"dataset '{name}' has dtype {array.dtype} in {location}: must be numeric")


def check_where(name: str, array: np.ndarray, good: np.ndarray, location, accepted: str, mask=None) -> None:
    """Refuse ``array`` where ``good`` is False (and ``mask``, broadcast, is True)."""
    check_numeric(name, array, location)
    bad = ~good if mask is None else ~good & mask
    found = _first_bad(bad, array)
    if found is not None:
        refuse(name, found[0], found[1], location, accepted)


def check_non_negative(name: str, array: np.ndarray, location, mask=None, upper=None) -> None:
    """Finite and ``>= 0`` (and ``<= upper`` when given)."""
    check_numeric(name, array, location)
    with np.errstate(invalid="ignore"):
        good = np.isfinite(array) & (array >= 0)
        if upper is not None:
            good &= array <= upper
    accepted = "must be finite and >= 0" if upper is None else f"must be in [0, {upper:g}]"
    check_where(name, array, good, location, accepted, mask)


def check_flags(name: str, array: np.ndarray, location, mask=None) -> None:
    """An int8 flag dataset holds only its flag values (:data:`FLAG_VALUES`)."""
    values = FLAG_VALUES[name]
    check_integer(name, array, location)
    check_where(name, array, np.isin(array, values), location,
                f"must be one of {', '.join(str(v) for v in values)}", mask)


def check_orders(order: np.ndarray, location) -> None:
    """The order axis as every writer makes it: ``1..K`` or ``0, 1..K`` (unique, sorted)."""
    check_integer("order", order, location)
    start = 0 if order.size and order[0] == 0 else 1
    expected = np.arange(start, start + order.size)
    bad = order != expected
    if order.size == 0 or bad.any():
        index, value = _first_bad(bad, order) if order.size else (None, order.tolist())
        refuse("order", index, value, location, f"the orders must be 1..K or 0, 1..K (unique, sorted); "
                                                f"found {order.tolist()}")


def check_estimator(estimator, order: np.ndarray, flags, location) -> None:
    """A known estimator whose ``order_source`` flags (when stored) are its own."""
    if not isinstance(estimator, str) or estimator not in ESTIMATORS:
        raise TableFormatError(f"attribute 'estimator' = {estimator!r} in {location}: must be one of "
                               f"{', '.join(ESTIMATORS)}")
    if flags is not None:
        expected = order_source(order, estimator)
        found = _first_bad(np.asarray(flags) != expected, np.asarray(flags))
        if found is not None:
            refuse("order_source", found[0], found[1], location,
                   f"must be {expected.tolist()} for estimator {estimator!r} (0 simulated, 1 analytic, "
                   "2 analytic f1 plus simulated)")


def check_albedo(brdf: np.ndarray, albedo: np.ndarray, area: np.ndarray, location, mask=None) -> None:
    """``albedo[..., k] = Σ_c brdf[..., k, c] Ω⊥_c`` for every order (to :data:`ALBEDO_RTOL`).

    ``brdf`` and ``albedo`` are already known finite and non-negative where ``mask`` holds.
    """
    total = np.einsum("...c,c->...", brdf, area)
    with np.errstate(invalid="ignore"):
        good = np.abs(albedo - total) <= ALBEDO_RTOL * np.maximum(albedo, total)
    found = _first_bad(~good if mask is None else ~good & mask, albedo)
    if found is not None:
        index, value = found
        refuse("albedo", index, value, location,
               f"must equal the sum of brdf x cell_projected_solid_angle over the cells, "
               f"{total[index]!r} (to {ALBEDO_RTOL:g} relative)")


def check_close(name: str, array: np.ndarray, expected: np.ndarray, location, what: str) -> None:
    """``array`` equals ``expected`` to :data:`GEOMETRY_RTOL` / :data:`GEOMETRY_ATOL`."""
    check_numeric(name, array, location)
    check_where(name, array, np.isfinite(array), location, "must be finite")
    good = np.isclose(array, expected, rtol=GEOMETRY_RTOL, atol=GEOMETRY_ATOL)
    found = _first_bad(~good, array)
    if found is not None:
        index, value = found
        refuse(name, index, value, location, f"must equal {what}, {np.asarray(expected)[index]!r}")


def check_degrees(name: str, degrees: np.ndarray, radians: np.ndarray, location, radians_name: str) -> None:
    """``degrees`` (as the config gave them) match ``radians`` as the writer requires."""
    check_numeric(name, degrees, location)
    with np.errstate(invalid="ignore"):
        good = np.isfinite(degrees) & np.isclose(np.radians(degrees), radians, rtol=GEOMETRY_RTOL,
                                                 atol=GEOMETRY_ATOL)
    check_where(name, degrees, good, location, f"must be finite and equal {radians_name} in degrees")


def check_sensor_datasets(cells: dict, sensor, location) -> None:
    """Each stored cell dataset equals the one of the rebuilt sensor (the reader uses
    the stored ``cell_projected_solid_angle`` for pdfs, sample weights and exports)."""
    for name, expected in (("cell_solid_angle", sensor.cell_solid_angle),
                           ("cell_projected_solid_angle", sensor.cell_projected_solid_angle),
                           ("theta_o", sensor.cell_theta), ("phi_o", sensor.cell_phi)):
        if name in cells:
            check_close(name, cells[name], np.asarray(expected, dtype=np.float64), location,
                        f"the value of the {sensor.resolution} x {sensor.resolution} sensor")


#: Sweep variables that hold integers, and those that hold one value per direction.
_SWEEP_FRACTIONS = ("absorbed", "truncated", "degenerate")


def check_sweep(sweep, radians: dict, location) -> None:
    """Refuse a sweep file (:class:`vcavity.io.sweep_table.SweepData`) holding values no
    sweep writes: the checks of a table, made on the points marked done.

    Parameters
    ----------
    sweep : SweepData
        As read, integer variables already known to be stored as integers.
    radians : dict
        The stored radians companion of each incidence axis or scalar (``theta_i``, ...).
    location : str
        How messages name the file.
    """
    check_orders(np.asarray(sweep.order), location)
    estimator = sweep.attrs.get("estimator", "analog")
    if not isinstance(estimator, str) or estimator not in ESTIMATORS:
        raise TableFormatError(f"attribute 'estimator' = {estimator!r} in {location}: must be one of "
                               f"{', '.join(ESTIMATORS)}")
    _check_sweep_sensor(sweep, location)
    _check_sweep_angles(sweep, radians, location)
    done = sweep.data["done"]
    check_flags("done", done, location)
    # a point is a position on the point axes: spread its flag over the incidence axes
    direction = (done == 1).reshape([len(a.values) if a.name in sweep.point_axes else 1 for a in sweep.axes])
    direction = np.broadcast_to(direction, sweep.shape)
    per_order, per_cell = direction[..., None], direction[..., None, None]
    data = sweep.data
    check_where("paths", data["paths"], data["paths"] == 0 if estimator == EXACT else data["paths"] >= 1,
                location, "must be 0 (estimator exact traces none)" if estimator == EXACT
                else "must be >= 1 where the point is done", direction)
    for name in ("counts", "unbinned_paths", "max_bounces_seen"):
        check_where(name, data[name], data[name] >= 0, location, "must be >= 0")
    for name in ("folded", "target_reached"):
        check_flags(name, data[name], location, direction)
    check_non_negative("brdf", data["brdf"], location, per_cell)
    check_non_negative("brdf_stderr", data["brdf_stderr"], location, per_cell)
    check_non_negative("albedo", data["albedo"], location, per_order)
    for name in _SWEEP_FRACTIONS:
        check_non_negative(name, data[name], location, direction, upper=1.0)
    with np.errstate(invalid="ignore"):
        check_where("relative_error", data["relative_error"], ~(data["relative_error"] < 0), location,
                    "must be >= 0 or NaN", direction)
    check_albedo(data["brdf"], data["albedo"], sweep.cells["cell_projected_solid_angle"], location, per_order)


def _check_sweep_sensor(sweep, location) -> None:
    """The stored cell geometry is that of the sensor the attributes name."""
    n_cells = len(sweep.cells["theta_o"])
    resolution = sweep.attrs.get("sensor_resolution")
    if isinstance(resolution, (bool, np.bool_)) or not isinstance(resolution, (int, np.integer)) \
            or resolution < 1 or resolution * resolution != n_cells:
        raise TableFormatError(f"attribute 'sensor_resolution' = {resolution!r} in {location}: must be N "
                               f"with N x N = {n_cells} (the cells stored)")
    sensor = EqualAreaSensor(int(resolution))
    check_close("cell_center", np.asarray(sweep.cells["cell_center"]), np.asarray(sensor.cell_center), location,
                f"the value of the {sensor.resolution} x {sensor.resolution} sensor")
    check_sensor_datasets(sweep.cells, sensor, location)


def _check_sweep_angles(sweep, radians: dict, location) -> None:
    """Incidence axes (and scalars) in range, each equal to its stored radians companion."""
    stored = {a.name: a.values for a in sweep.axes}
    stored.update({key: (value,) for key, value in sweep.scalars.items()})
    for name, companion in (("theta_i_deg", "theta_i"), ("phi_i_deg", "phi_i")):
        if name not in stored:
            continue
        try:
            degrees = np.asarray(stored[name], dtype=np.float64)
        except (TypeError, ValueError):
            raise TableFormatError(f"dataset '{name}' = {list(stored[name])!r} in {location}: "
                                   "must hold numbers") from None
        good = (degrees >= 0) & (degrees <= 90) if name == "theta_i_deg" else np.isfinite(degrees)
        check_where(name, degrees, good, location,
                    "must be in [0, 90] degrees" if name == "theta_i_deg" else "must be finite")
        if companion in radians:
            check_degrees(name, degrees, np.asarray(radians[companion], dtype=np.float64).reshape(degrees.shape),
                          location, companion)


__all__ = ["ALBEDO_RTOL", "FLAG_VALUES", "TableFormatError", "check_albedo", "check_close", "check_degrees", "check_estimator",
           "check_flags", "check_integer", "check_non_negative", "check_numeric", "check_orders", "check_sensor_datasets", "check_sweep",
           "check_where", "refuse"]
