"""HDF5 BRDF tables: the in-memory :class:`Table`, :func:`open_table` and :func:`write_table`.

``vcavity.io`` is the only part of vcavity that imports h5py; none of it imports Numba
(an import-linter contract, pyproject.toml), so reading a table compiles nothing. The layout (format v3, netCDF-4 compatible) is
documented in ``docs/hdf5-format.md`` and defined in :mod:`vcavity.io.schema`; writing is
in :mod:`vcavity.io.writer`. Tables of format v1 and v2 are still read. The tabulated quantity
is the cell-averaged, cosine-weighted BRDF of physics.md section 6::

    brdf[c] = (1/Ω⊥_c) ∫_c f_k(i, o) cos θ_o dω_o  ≈  counts[c] / (paths Ω⊥_c)
"""

from __future__ import annotations

import errno
import json
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import h5py
import numpy as np

from vcavity.io import checks
from vcavity.io.checks import TableFormatError, attribute_value
from vcavity.io.schema import (
    DATASETS,
    FORMAT_NAME,
    FORMAT_VERSION,
    READABLE_VERSIONS,
    REQUIRED_ROOT_ATTRS,
    ROOT_ATTRS_AS_FIELDS,
    V1_DATASETS,
    V3_ADDED_DATASETS,
)
from vcavity.io.writer import write_table
from vcavity.sensor.grid import EqualAreaSensor


@dataclass(frozen=True, eq=False)
class Table:
    """Everything a vcavity table holds, read into memory (arrays are read-only).

    Axes: incidence ``n_i``, order ``n_k``, cell ``n_c``; see docs/hdf5-format.md.
    A table is also a continuous BRDF for renderers: :meth:`eval`, :meth:`sample`,
    :meth:`pdf`, :meth:`albedo_at` (docs/table-api.md).

    Attributes
    ----------
    path : pathlib.Path
    theta_i, phi_i : ndarray (n_i,)
        Incident direction in rad (theta from +z, phi from +x toward +y).
    theta_i_deg, phi_i_deg : ndarray (n_i,)
        The same in degrees, as written in the run configuration (format v1 tables:
        ``np.degrees`` of the radians).
    order : ndarray of int64 (n_k,)
        Bounce orders: 0 = all orders together (``f_inf``), then 1..K.
    brdf, brdf_stderr : ndarray (n_i, n_k, n_c)
        Cell-averaged cosine-weighted BRDF and its standard error, 1/sr.
    counts : ndarray of int64 (n_i, n_k, n_c)
    albedo : ndarray (n_i, n_k)
    absorbed, truncated, degenerate : ndarray (n_i,)
        Fractions of paths.
    paths, max_bounces_seen : ndarray of int64 (n_i,)
    cell_center, cell_solid_angle, cell_projected_solid_angle : ndarray (n_c, 3), (n_c,)
    theta_o, phi_o : ndarray (n_c,)
        Polar angle and azimuth (in (-pi, pi]) of each cell centre, rad.
    sensor : EqualAreaSensor
        Rebuilt from the stored resolution; bins exactly as the run did.
    material, config : dict
        The ``/material`` attributes and the parsed resolved run configuration.
    seed, format_version : int
    vcavity_version : str
    attrs : dict
        The remaining root attributes (``block_size``, ``max_bounces``, ``estimator``,
        ``target_error``, ``device``, ...).
    order_source : ndarray of int8 (n_k,)
        0 simulated, 1 analytic, 2 analytic f1 plus simulated orders (format 3).
    unbinned_paths : ndarray of int64 (n_i,)
        Exact-f1: paths that left after one bounce, counted, not binned.
    folded : ndarray of int8 (n_i,)
        1 where brdf averages mirror cells about the plane of incidence.
    relative_error : ndarray (n_i,)
        Energy-weighted relative standard error of f_inf (NaN without f_inf or before v3).
    target_reached : ndarray of int8 (n_i,)
        -1 without a target error, else 0 / 1.
    """

    path: Path
    theta_i: np.ndarray
    phi_i: np.ndarray
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    order: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray
    counts: np.ndarray
    albedo: np.ndarray
    absorbed: np.ndarray
    truncated: np.ndarray
    degenerate: np.ndarray
    paths: np.ndarray
    max_bounces_seen: np.ndarray
    cell_center: np.ndarray
    cell_solid_angle: np.ndarray
    cell_projected_solid_angle: np.ndarray
    theta_o: np.ndarray
    phi_o: np.ndarray
    sensor: EqualAreaSensor
    material: dict
    config: dict
    seed: int
    format_version: int
    vcavity_version: str
    attrs: dict = field(default_factory=dict)
    order_source: np.ndarray | None = None
    unbinned_paths: np.ndarray | None = None
    folded: np.ndarray | None = None
    relative_error: np.ndarray | None = None
    target_reached: np.ndarray | None = None

    @property
    def estimator(self) -> str:
        """``analog``, ``exact-f1``, ``paper`` or ``exact`` (tables before format 3: ``analog``)."""
        return str(self.attrs.get("estimator", "analog"))

    @property
    def device(self) -> str:
        """Where the walk ran: ``"cpu"`` or ``"cuda"`` (tables written before the attribute: ``"cpu"``)."""
        return str(self.attrs.get("device", "cpu"))

    @property
    def deterministic(self) -> bool:
        """True for a model's table (estimator ``exact``): no paths, ``brdf_stderr`` is the
        model's error estimate, every order analytic."""
        return bool(self.attrs.get("deterministic", 0))

    def is_analytic(self, k: int) -> bool:
        """Whether order ``k`` of this table comes (at least partly) from the analytic model."""
        if self.order_source is None:
            return False
        return bool(self.order_source[self.order_index(k)] != 0)

    def order_index(self, k: int) -> int:
        """Position of bounce order ``k`` on the order axis (``self.order[j] == k``).

        Raises
        ------
        ValueError
            If order ``k`` is not in the table.
        """
        hits = np.flatnonzero(self.order == k)
        if hits.size == 0:
            present = ", ".join(str(int(o)) for o in self.order)
            raise ValueError(f"order {k} is not in table {self.path} (orders present: {present})")
        return int(hits[0])

    # The renderer API (docs/table-api.md) lives in vcavity.brdf.table_brdf (plain NumPy, no Numba);
    # imported on first use so that reading a table needs none of it.
    @cached_property
    def interpolant(self):
        """The table as a continuous BRDF, :class:`vcavity.brdf.table_brdf.TableBRDF` (built once)."""
        from vcavity.brdf.table_brdf import TableBRDF

        return TableBRDF(self)

    def eval(self, wi, wo, order=0):
        """Interpolated BRDF f(wi, wo) in 1/sr; see :meth:`vcavity.brdf.table_brdf.TableBRDF.eval`."""
        return self.interpolant.eval(wi, wo, order)

    def pdf(self, wi, wo, order=0):
        """Density of :meth:`sample` in 1/sr; see :meth:`vcavity.brdf.table_brdf.TableBRDF.pdf`."""
        return self.interpolant.pdf(wi, wo, order)

    def sample(self, wi, u1, u2, order=0):
        """``(wo, weight, pdf)`` from the table; see :meth:`vcavity.brdf.table_brdf.TableBRDF.sample`."""
        return self.interpolant.sample(wi, u1, u2, order)

    def albedo_at(self, wi, order=0):
        """Directional albedo at any ``wi`` (``self.albedo`` is the stored (n_i, n_k) array);
        see :meth:`vcavity.brdf.table_brdf.TableBRDF.albedo`."""
        return self.interpolant.albedo(wi, order)


def open_table(path) -> Table:
    """Read a vcavity BRDF table (format v3, v2 or v1) into memory.

    Parameters
    ----------
    path : str or os.PathLike
        An HDF5 file written by :func:`write_table` (``vcavity run``).

    Returns
    -------
    Table

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    TableFormatError
        One-line message if the file is not HDF5, not a vcavity table, of another format
        version, lacks a dataset or attribute, has inconsistent shapes, or holds values
        no run writes (:func:`_check_values`: NaN or negative BRDF values, an albedo that
        is not the sum of ``brdf`` x projected solid angle, sensor datasets that are not
        the sensor's, repeated or unsorted orders, degrees that are not the radians,
        fractional counts, flags out of range).
    """
    location = Path(os.fspath(path))
    if not location.exists():
        raise FileNotFoundError(errno.ENOENT, "no such vcavity table", str(location))
    if not location.is_file():  # a folder is no table, and reading a FIFO would block
        raise TableFormatError(f"not a vcavity table: {location} (not a regular file)")
    if not h5py.is_hdf5(location):
        raise TableFormatError(f"not a vcavity table: {location} (not an HDF5 file)")
    try:
        with h5py.File(location, "r") as h5:
            return _read(h5, location)
    except (OSError, KeyError) as exc:
        first_line = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise TableFormatError(f"cannot read vcavity table {location}: {first_line}") from exc


def _read(h5: h5py.File, location: Path) -> Table:
    root = h5.attrs
    if attribute_value(root.get("format")) != FORMAT_NAME:
        raise TableFormatError(f"not a vcavity table: {location}")
    for name in ("format_version",) + REQUIRED_ROOT_ATTRS:
        if name not in root:
            raise TableFormatError(f"missing attribute '{name}' in {location}")
    version = attribute_value(root["format_version"])
    if version not in READABLE_VERSIONS:
        readable = ", ".join(str(v) for v in READABLE_VERSIONS)
        raise TableFormatError(f"unsupported format_version {version} in {location} "
                               f"(this vcavity reads {readable})")
    names = V1_DATASETS if version == 1 else tuple(DATASETS) if version >= 3 else tuple(
        name for name in DATASETS if name not in V3_ADDED_DATASETS)
    for name in names:
        if not isinstance(h5.get(name), h5py.Dataset):
            raise TableFormatError(f"missing dataset '{name}' in {location}")
    if not isinstance(h5.get("material"), h5py.Group):
        raise TableFormatError(f"missing group 'material' in {location}")

    data = {name: h5[name][()] for name in names if name not in ("incidence", "cell", "xyz")}
    checks.check_shapes(data, checks.int_attribute(root, "n_cells", location, 1), location)
    seed = checks.int_attribute(root, "seed", location, 0, 2**64 - 1)
    try:
        config = json.loads(attribute_value(root["config"]))
    except (TypeError, ValueError) as exc:
        raise TableFormatError(f"attribute 'config' is not valid JSON in {location}") from exc
    sensor = checks.sensor_of(root, data["cell_center"], location)
    checks.check_sensor_datasets(data, sensor, location)
    deterministic = bool(attribute_value(root.get("deterministic", 0)))
    checks.check_values(data, location, deterministic)
    if version >= 3:
        checks.check_estimator_name(attribute_value(root.get("estimator", "analog")), location)
        checks.check_order_source(data["order_source"], deterministic, location)
    if version == 1:  # v1 had no degrees and no outgoing angles: derive them
        data.update(theta_i_deg=np.degrees(data["theta_i"]), phi_i_deg=np.degrees(data["phi_i"]),
                    theta_o=np.array(sensor.cell_theta), phi_o=np.array(sensor.cell_phi))
    if version < 3:  # before the estimators: analog, unfolded, no target
        n_i, n_k = data["theta_i"].size, data["order"].size
        data.update(order_source=np.zeros(n_k, np.int8), unbinned_paths=np.zeros(n_i, np.int64),
                    folded=np.zeros(n_i, np.int8), relative_error=np.full(n_i, np.nan),
                    target_reached=np.full(n_i, -1, np.int8))
    for array in data.values():
        array.setflags(write=False)
    return Table(
        path=location, sensor=sensor,
        material={key: attribute_value(value) for key, value in h5["material"].attrs.items()
                  if key != "description"},
        config=config, seed=seed, format_version=int(version),
        vcavity_version=str(attribute_value(root["vcavity_version"])),
        attrs={key: attribute_value(value) for key, value in root.items()
               if key not in ROOT_ATTRS_AS_FIELDS},
        **data,
    )


__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Table", "TableFormatError", "open_table",
           "write_table"]
