"""The numbers each plot draws, computed without matplotlib (and tested without pixels).

- :func:`slice_data`: in-plane slices of a table (physics.md sec. 6 cell averages along
  the plane of incidence, :mod:`vcavity.sensor.plane`) with the single-bounce models
  (physics.md sec. 7) averaged over the same cells.
- :func:`albedo_data`: albedo per order and the inter-reflection share
  ``(f_inf - f1)/f_inf`` against ``theta_i``, with binomial standard errors.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from vcavity.sensor.directions import incident_vector
from vcavity.sensor.plane import plane_segments

#: Overlay models of a slice: name as ``vcavity compare --model`` spells it -> legend label.
SLICE_MODELS = {"vcavity": "V-cavity model", "smith": "Smith model"}


@dataclass(frozen=True)
class SliceData:
    """One in-plane slice: step values along the plane of incidence.

    Attributes
    ----------
    index : int
        Incidence index in the table.
    theta_i_deg, phi_i_deg : float
    edges : ndarray (n + 1,)
        Signed theta_o (deg) bounding each stretch inside one cell; > 0 is the specular
        side (phi_o = phi_i + 180 deg), < 0 back toward the light (phi_o = phi_i).
    cells : ndarray of int64 (n, 2)
        The cells either side of the plane along each stretch (equal but on borders).
    brdf, stderr : dict
        Order -> (n,) table values (1/sr) and standard errors along the stretches (of a
        deterministic table, the model's error estimates: see ``model_error``).
    models : dict
        Model name (:data:`SLICE_MODELS`) -> (n,) its f1 cell averages (1/sr) along the
        stretches; missing where the model does not apply.
    notes : list of str
        Why a requested model is missing.
    model_error : bool
        The table is a deterministic model's (estimator exact): ``stderr`` holds the
        model's own error estimate, not a statistical error.
    """

    index: int
    theta_i_deg: float
    phi_i_deg: float
    edges: np.ndarray
    cells: np.ndarray
    brdf: dict
    stderr: dict
    models: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    model_error: bool = False

    @property
    def centers(self) -> np.ndarray:
        """Mid signed theta_o (deg) of each stretch."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


def _along(values, cells):
    """Mean of a per-cell array over the two sides of each stretch."""
    return 0.5 * (values[cells[:, 0]] + values[cells[:, 1]])


def _along_stderr(stderr, cells):
    """Standard error of :func:`_along`: one cell's where both sides agree, else of the mean
    of two (independent up to the multinomial's small negative covariance, neglected)."""
    a, b = stderr[cells[:, 0]], stderr[cells[:, 1]]
    return np.where(cells[:, 0] == cells[:, 1], a, 0.5 * np.hypot(a, b))


def build_models(table, names):
    """Single-bounce models of a table's material, ``{name: model}``, and notes.

    Imports the analytic package (Numba) only when called. A model that does not apply
    to the material (e.g. Smith on a Gaussian distribution) is left out with a note.

    Raises
    ------
    vcavity.analytic.single_bounce.ModelNotApplicable
        If the table's material is not understood.
    """
    if not names:
        return {}, []
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.compare import build_model, material_of_table

    material = material_of_table(table)
    models, notes = {}, []
    for name in names:
        try:
            models[name] = build_model(material, name)
        except ModelNotApplicable as exc:
            notes.append(f"{SLICE_MODELS[name]} left out: {str(exc).splitlines()[0]}")
    return models, notes


def slice_data(table, index: int, orders, models=None, notes=()) -> SliceData:
    """In-plane slice of incidence ``index`` of ``table`` (module docstring).

    Parameters
    ----------
    table : vcavity.io.table.Table
    index : int
        Incidence index.
    orders : sequence of int
        Orders present in the table (0 = f_inf).
    models : dict, optional
        ``{name: SingleBounceModel}`` (:func:`build_models`); each is averaged over the
        slice's cells exactly as the table is (``vcavity.analytic.cells.cell_average``,
        physics.md sec. 6), so it is comparable with the f1 steps stretch by stretch.
    notes : sequence of str
        Carried into :attr:`SliceData.notes`.

    Returns
    -------
    SliceData
    """
    theta_i, phi_i = float(table.theta_i[index]), float(table.phi_i[index])
    segments = plane_segments(table.sensor.resolution, phi_i)
    cells = segments.cells
    brdf, stderr = {}, {}
    for k in orders:
        row = table.order_index(int(k))
        brdf[int(k)] = _along(np.asarray(table.brdf[index, row]), cells)
        stderr[int(k)] = _along_stderr(np.asarray(table.brdf_stderr[index, row]), cells)
    curves = {}
    if models:
        from vcavity.analytic.cells import cell_average

        unique = np.unique(cells)
        incident = incident_vector(theta_i, phi_i)
        for name, model in models.items():
            per_cell = np.zeros(table.sensor.n_cells)
            per_cell[unique] = cell_average(model, incident, table.sensor, cells=unique)
            curves[name] = _along(per_cell, cells)
    return SliceData(index=int(index), theta_i_deg=float(table.theta_i_deg[index]),
                     phi_i_deg=float(table.phi_i_deg[index]), edges=segments.edges, cells=cells,
                     brdf=brdf, stderr=stderr, models=curves, notes=list(notes),
                     model_error=bool(table.deterministic))


@dataclass(frozen=True)
class AlbedoData:
    """Albedo per order against theta_i, grouped by phi_i (one curve per azimuth).

    Attributes
    ----------
    groups : list of (phi_i_deg, indices)
        Incidence indices of each azimuth, sorted by theta_i.
    theta_i_deg : ndarray (n_i,)
    albedo, stderr : dict
        Order -> (n_i,) albedo and binomial standard error ``sqrt(a (1 - a)/paths)``; of a
        deterministic table (``model_error``), the model's error of the albedo: its cells'
        error estimates summed, ``sum_c brdf_stderr_c * projected solid angle_c``.
    share, share_stderr : ndarray (n_i,) or None
        ``(albedo_inf - albedo_1)/albedo_inf``, the fraction of the exiting light that
        bounced more than once, and its binomial standard error ``sqrt(s (1 - s)/n_inf)``
        (the f1 exits are a subset of the n_inf exits); None without f_inf or f1 (the
        error also for a deterministic table).
    model_error : bool
        The table is a deterministic model's (estimator exact): no path, no statistical error.
    """

    groups: list
    theta_i_deg: np.ndarray
    albedo: dict
    stderr: dict
    share: np.ndarray | None
    share_stderr: np.ndarray | None
    model_error: bool = False


def albedo_data(table, orders) -> AlbedoData:
    """Albedos and inter-reflection share of ``table`` (see :class:`AlbedoData`)."""
    paths = np.asarray(table.paths, dtype=np.float64)
    model_error = bool(table.deterministic)  # no path traced: no binomial error, the model's own
    albedo, stderr = {}, {}
    for k in orders:
        a = np.asarray(table.albedo[:, table.order_index(int(k))], dtype=np.float64)
        albedo[int(k)] = a
        if model_error:
            cells = np.asarray(table.brdf_stderr[:, table.order_index(int(k))], dtype=np.float64)
            stderr[int(k)] = cells @ np.asarray(table.sensor.cell_projected_solid_angle, dtype=np.float64)
        else:
            stderr[int(k)] = np.sqrt(np.clip(a * (1.0 - a), 0.0, None) / paths)
    share = share_stderr = None
    present = set(int(k) for k in table.order)
    if {0, 1} <= present:
        a_inf = np.asarray(table.albedo[:, table.order_index(0)], dtype=np.float64)
        a_1 = np.asarray(table.albedo[:, table.order_index(1)], dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(a_inf > 0, (a_inf - a_1) / a_inf, np.nan)
            exits = a_inf * paths
            share_stderr = None if model_error else np.sqrt(np.clip(share * (1.0 - share), 0.0, None) / exits)
    theta = np.asarray(table.theta_i_deg, dtype=np.float64)
    phi = np.round(np.asarray(table.phi_i_deg, dtype=np.float64), 9)
    groups = []
    for value in np.unique(phi):
        members = np.flatnonzero(phi == value)
        groups.append((float(value), members[np.argsort(theta[members], kind="stable")]))
    return AlbedoData(groups=groups, theta_i_deg=theta, albedo=albedo, stderr=stderr, share=share,
                      share_stderr=share_stderr, model_error=model_error)


def warn(message: str) -> None:
    """One line on stderr, the way the CLI reports notes."""
    print(f"vcavity: note: {message}", file=sys.stderr)
