"""Checks of what a table or sweep file holds, made when it is read (plain NumPy).

A file edited by hand or damaged on the way (NaN or negated ``brdf``, a scaled
``albedo``, zeroed solid angles, repeated orders, fractional counts, flags out of range,
a sweep's ``done`` flag out of range) must not be read as a table: every consumer
(``info``, ``compare``, ``plot``, ``export``, ``sweep --resume``, the table API) would
report or export nonsense. :func:`vcavity.io.table.open_table` and
:func:`vcavity.io.sweep_table.open_sweep` refuse such a file with a one-line
:class:`TableFormatError` naming the dataset; the checks below are the ones that are cheap
(one pass over each array, no model, no simulation), and they only refuse values that no
run of vcavity produces. The writer (writer.py) makes the same checks of a table before it
writes one (:func:`check_table`): what vcavity writes, it reads.

The checks know no estimator by name: what a table's ``estimator`` attribute means is the
estimators' business (:mod:`vcavity.estimators.registry`), which the consumers that need
it ask; a table is checked by what it says of itself (``deterministic``, its flags).
"""

from __future__ import annotations

import numpy as np

from vcavity.io.schema import DATASETS
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
    value = attribute_value(value)  # a NumPy scalar's repr (np.float64(0.5)) is no value a user wrote
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


def check_estimator_name(estimator, location) -> None:
    """The ``estimator`` attribute names one (what it means is the estimators' to say)."""
    if not isinstance(estimator, str) or not estimator:
        raise TableFormatError(f"attribute 'estimator' = {estimator!r} in {location}: must name an estimator")


def check_order_source(flags, deterministic: bool, location) -> None:
    """A deterministic table (a model's) has every order analytic (flag 1)."""
    if deterministic:
        flags = np.asarray(flags)
        found = _first_bad(flags != 1, flags)
        if found is not None:
            refuse("order_source", found[0], found[1], location,
                   "must be 1 (analytic) for every order of a deterministic table")


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
               f"{attribute_value(total[index])!r} (to {ALBEDO_RTOL:g} relative)")


def check_close(name: str, array: np.ndarray, expected: np.ndarray, location, what: str) -> None:
    """``array`` equals ``expected`` to :data:`GEOMETRY_RTOL` / :data:`GEOMETRY_ATOL`."""
    check_numeric(name, array, location)
    check_where(name, array, np.isfinite(array), location, "must be finite")
    good = np.isclose(array, expected, rtol=GEOMETRY_RTOL, atol=GEOMETRY_ATOL)
    found = _first_bad(~good, array)
    if found is not None:
        index, value = found
        refuse(name, index, value, location, f"must equal {what}, {attribute_value(np.asarray(expected)[index])!r}")


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
    check_estimator_name(sweep.attrs.get("estimator", "analog"), location)
    # sweeps written before the attribute: 0 paths are a model's points (estimator exact)
    deterministic = sweep.attrs.get("deterministic")
    _check_sweep_sensor(sweep, location)
    _check_sweep_angles(sweep, radians, location)
    done = sweep.data["done"]
    check_flags("done", done, location)
    # a point is a position on the point axes: spread its flag over the incidence axes
    direction = (done == 1).reshape([len(a.values) if a.name in sweep.point_axes else 1 for a in sweep.axes])
    direction = np.broadcast_to(direction, sweep.shape)
    per_order, per_cell = direction[..., None], direction[..., None, None]
    data = sweep.data
    if deterministic is None:
        good, accepted = data["paths"] >= 0, "must be >= 0 where the point is done"
    elif deterministic:
        good, accepted = data["paths"] == 0, "must be 0 (a deterministic sweep traces none)"
    else:
        good, accepted = data["paths"] >= 1, "must be >= 1 where the point is done"
    check_where("paths", data["paths"], good, location, accepted, direction)
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
        raise TableFormatError(f"attribute 'sensor_resolution' = {attribute_value(resolution)!r} in {location}: "
                               f"must be N with N x N = {n_cells} (the cells stored)")
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
            raise TableFormatError(f"dataset '{name}' = {attribute_value(np.asarray(stored[name], dtype=object))!r} in "
                                   f"{location}: "
                                   "must hold numbers") from None
        good = (degrees >= 0) & (degrees <= 90) if name == "theta_i_deg" else np.isfinite(degrees)
        check_where(name, degrees, good, location,
                    "must be in [0, 90] degrees" if name == "theta_i_deg" else "must be finite")
        if companion in radians:
            check_degrees(name, degrees, np.asarray(radians[companion], dtype=np.float64).reshape(degrees.shape),
                          location, companion)


def attribute_value(value):
    """An HDF5 attribute as a Python value (bytes decoded, NumPy scalars unwrapped)."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, (np.generic, np.ndarray)):
        return value.tolist()
    return value


def check_shapes(data: dict, n_cells: int, location) -> None:
    """Each dataset has the shape of its axes (:data:`vcavity.io.schema.DATASETS`)."""
    sizes = {"incidence": data["theta_i"].size, "order": data["order"].size, "cell": n_cells, "xyz": 3}
    for name, array in data.items():
        expected = tuple(sizes[axis] for axis in DATASETS[name][0])
        if array.shape != expected:
            raise TableFormatError(f"dataset '{name}' has shape {array.shape}, expected {expected} in {location}")


def sensor_of(root, cell_center: np.ndarray, location) -> EqualAreaSensor:
    """The sensor that root attributes ``root`` name, checked to reproduce the stored cell centres."""
    # An N x N sensor has N^2 cells: bounding N by the stored cell count keeps a corrupt
    # attribute from building a huge sensor before the comparison below refuses it.
    resolution = int_attribute(root, "sensor_resolution", location, 1, cell_center.shape[0])
    sensor = EqualAreaSensor(resolution)
    partition = attribute_value(root["sensor_partition"])
    if partition != sensor.partition:
        raise TableFormatError(f"table uses sensor partition '{partition}', this vcavity "
                               f"provides '{sensor.partition}' in {location}")
    if sensor.n_cells != cell_center.shape[0] or not np.allclose(
            sensor.cell_center, cell_center, rtol=0.0, atol=1e-12):
        raise TableFormatError(f"sensor of resolution {resolution} does not reproduce the "
                               f"stored cell centres in {location}")
    return sensor


def int_attribute(root, name: str, location, lo: int, hi: int | None = None) -> int:
    """Root attribute ``name`` as an int in ``[lo, hi]``, or a one-line TableFormatError."""
    value = attribute_value(root[name])
    if isinstance(value, bool) or not isinstance(value, int) or value < lo or (hi is not None and value > hi):
        accepted = f"an integer >= {lo}" + (f" and <= {hi}" if hi is not None else "")
        raise TableFormatError(f"attribute '{name}' = {value!r} in {location}: must be {accepted}")
    return value


def check_values(data: dict, location, deterministic: bool = False) -> None:
    """Refuse values no run writes (the reader and the writer both ask); a deterministic
    table (a model's: no path traced) has 0 paths."""
    for name in ("paths", "counts", "max_bounces_seen", "unbinned_paths"):
        if name in data:
            check_integer(name, data[name], location)
    for name, good, accepted in (
            ("paths", (lambda a: a == 0) if deterministic else (lambda a: a >= 1),
             "must be 0 (a deterministic table traced none)" if deterministic
             else "must be >= 1 (every direction traced paths)"),
            ("counts", lambda a: a >= 0, "must be >= 0"),
            ("max_bounces_seen", lambda a: a >= 0, "must be >= 0"),
            ("unbinned_paths", lambda a: a >= 0, "must be >= 0"),
            ("theta_i", lambda a: (a >= 0.0) & (a <= 0.5 * np.pi), "must be in [0, pi/2] rad"),
            ("phi_i", np.isfinite, "must be finite")):
        if name in data:
            check_numeric(name, data[name], location)
            with np.errstate(invalid="ignore"):
                check_where(name, data[name], good(data[name]), location, accepted)
    check_orders(data["order"], location)
    for name in ("brdf", "brdf_stderr", "albedo", "cell_solid_angle", "cell_projected_solid_angle"):
        check_non_negative(name, data[name], location)
    for name in ("absorbed", "truncated", "degenerate"):  # fractions of paths (or of energy)
        check_non_negative(name, data[name], location, upper=1.0)
    for name in ("theta_i_deg", "phi_i_deg"):  # v2 and later: the degrees the config gave
        if name in data:
            check_degrees(name, data[name], data[name.removesuffix("_deg")], location,
                                 name.removesuffix("_deg"))
    for name in ("order_source", "folded", "target_reached"):
        if name in data:
            check_flags(name, data[name], location)
    if "relative_error" in data:  # NaN without f_inf, inf while nothing exited
        with np.errstate(invalid="ignore"):
            check_where("relative_error", data["relative_error"],
                               ~(data["relative_error"] < 0), location, "must be >= 0 or NaN")
    check_albedo(data["brdf"], data["albedo"], data["cell_projected_solid_angle"], location)


__all__ = ["ALBEDO_RTOL", "FLAG_VALUES", "TableFormatError", "attribute_value", "check_albedo", "check_close",
           "check_degrees", "check_estimator_name", "check_flags", "check_integer", "check_non_negative", "check_numeric",
           "check_order_source", "check_orders", "check_sensor_datasets", "check_shapes", "check_sweep", "check_values",
           "check_where", "int_attribute", "refuse", "sensor_of"]
