"""Models averaged over sensor cells exactly as a table stores them (physics.md sec. 6).

A table holds ``brdf[c] = (1/Ω⊥_c) ∫_c f(i, o) cos θ_o dω_o`` and a simulation's
expected count of order ``k`` in cell ``c`` is ``N_paths ∫_c f_k cos θ_o dω_o``. The
integral over a cell is a Gauss-Legendre rule in the sensor's square coordinates
(:func:`vcavity.analytic.quadrature.subcell_quadrature`, which splits the cells that
the concentric map's kinks cross), never a value at the cell centre.

Sub-points per cell: the smooth body term needs few (``DEFAULT_BODY_SUB = 4``, and 8 on
the diagonal and horizon cells: measured relative error of a cell integral about 1e-6
against 16 x 16 and against brute force, docs/validation.md). The specular term gets
``MIN_SPECULAR_SUB = 16`` points, and where its lobe is finer than they resolve (a lobe
narrower than a cell, an anisotropic ridge, the wedge of any lobe at grazing incidence)
it is integrated over the half vector instead (:mod:`vcavity.analytic.specular_peak`).
:func:`specular_subpoints` is the older rule of thumb (points for a lobe of width w).
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.analytic.batches import in_batches
from vcavity.analytic.quadrature import (
    MAX_SPECULAR_SUB,
    MIN_SPECULAR_SUB,
    radius_split_quadrature,
    subcell_quadrature,
)
from vcavity.analytic.single_bounce import SingleBounceModel
from vcavity.analytic.specular_peak import (
    DEFAULT_AZIMUTH_NODES,
    DEFAULT_RADIAL_NODES,
    peak_integrals,
)
from vcavity.analytic.peak_cells import peak_cells
from vcavity.sensor.grid import EqualAreaSensor

DEFAULT_BODY_SUB = 4
#: Work (points x ``point_cost``) of the first batch of :func:`integrate_cells`.
_FIRST_WORK = 1 << 22
DEFAULT_SUB = 8
#: Sub-points per roughness width across a cell (see specular_subpoints).
SPECULAR_POINTS_PER_WIDTH = 6.0


def specular_subpoints(model: SingleBounceModel, sensor: EqualAreaSensor) -> int:
    """Sub-points per cell side for the specular term.

    ``ceil(6 δ / w)`` clipped to [16, 48], with ``δ = sqrt(2π)/N`` the angular side of a
    cell and ``w`` the roughness width (the distribution's ``lobe_width``, :mod:`vcavity.microfacet.registry`).
    The specular lobe in ``o`` is about ``2 w`` wide; measured relative error of the
    specular albedo summed over cells below 1e-7 and of any cell below 1e-5 of the
    largest cell with this rule for alpha >= 0.05 at N = 57 (docs/validation.md).
    """
    cell_angle = math.sqrt(2.0 * math.pi) / sensor.resolution
    wanted = math.ceil(SPECULAR_POINTS_PER_WIDTH * cell_angle / max(model.lobe_width, 1e-6))
    return int(min(max(wanted, MIN_SPECULAR_SUB), MAX_SPECULAR_SUB))


def _hard_cells(cells, resolution):
    """Cells on the diagonals ``|u| = |v|`` (kinks of the concentric map, split by the
    sensor's rule) and on the horizon ring (where ``G1_V(o)`` vanishes linearly)."""
    ix, iy = cells % resolution, cells // resolution
    last = resolution - 1
    return (ix == iy) | (ix + iy == last) | (ix == 0) | (iy == 0) | (ix == last) | (iy == last)


def integrate_cells(projected, incident, sensor, n_sub, cells, chunk_points=262144, kink_z=None, hard_sub=8,
                    corner_sub=16, point_cost=1, should_stop=None):
    """``Σ_q w_q projected(i, o_q)`` per cell, in batches of cells to bound memory and time.

    Diagonal and horizon cells (:func:`_hard_cells`) get at least 8 x 8 points: with
    4 x 4 the body term of the horizon corner cells was off by 1.6e-3 (2 x 2 points per
    Duffy triangle) and of other horizon cells by 2.4e-5; with 8 x 8 by 1e-6 except the
    four corner cells (1.7e-5), which get 16 x 16 (2.4e-7) (``hard_sub``, ``corner_sub``:
    the error estimates of :mod:`vcavity.analytic.exact_f1` halve them). With ``kink_z``
    the off-diagonal cells that the circle ``z = kink_z`` crosses are cut along it
    (:func:`~vcavity.analytic.quadrature.radius_split_quadrature`, ``max(n_sub, hard_sub)``
    points on each side).

    A batch holds at most ``chunk_points`` points; the first is sized by ``point_cost``
    (the work of one point, e.g. the body's nodes over ``m``) and the later ones by time
    (:func:`vcavity.analytic.batches.in_batches`, ``should_stop`` polled between them).
    Each cell's sum is its own, so the batches do not change the result.
    """
    cells = np.arange(sensor.n_cells) if cells is None else np.asarray(cells, dtype=np.int64)
    out = np.empty(cells.size)
    n = sensor.resolution
    hard = _hard_cells(cells, n)
    ix, iy = cells % n, cells // n
    last = n - 1
    corner = ((ix == 0) | (ix == last)) & ((iy == 0) | (iy == last))
    split = np.zeros(cells.size, dtype=bool)
    if kink_z is not None:
        radius = math.sqrt(min(max(1.0 - kink_z, 0.0), 1.0))
        u_centre, v_centre = -1.0 + (2 * ix + 1.0) / n, -1.0 + (2 * iy + 1.0) / n
        r_centre = np.maximum(np.abs(u_centre), np.abs(v_centre))
        diagonal = (ix == iy) | (ix + iy == last)
        split = ~diagonal & (np.abs(r_centre - radius) < 1.0 / n)
    for group, size in ((~hard & ~split, n_sub), (hard & ~corner & ~split, max(n_sub, hard_sub)),
                        (corner, max(n_sub, corner_sub)),
                        (split, max(n_sub, hard_sub) if kink_z is not None else n_sub)):
        positions = np.flatnonzero(group)
        points = 2 * size * size  # per cell, at most (a split cell's two sides)

        def batch(start, stop, group=group, size=size, positions=positions):
            chosen = positions[start:stop]
            if group is split:
                directions, weights = radius_split_quadrature(sensor, int(size), cells[chosen], radius)
            else:
                directions, weights = subcell_quadrature(sensor, int(size), cells=cells[chosen])
            values = projected(incident, directions.reshape(-1, 3)).reshape(weights.shape)
            out[chosen] = np.sum(values * weights, axis=1)

        in_batches(positions.size, _FIRST_WORK // (points * max(int(point_cost), 1)), batch, should_stop,
                   maximum=max(1, chunk_points // points))
    return out


def cell_integrals(model, incident, sensor: EqualAreaSensor, cells=None, n_sub=None,
                   n_sub_body=DEFAULT_BODY_SUB, n_sub_specular=None) -> np.ndarray:
    """``∫_c f(i, o) cos θ_o dω_o`` for each cell (physics.md sec. 6).

    Parameters
    ----------
    model : SingleBounceModel or object with ``projected(incident, outgoing)``
        ``projected`` returns ``f cos θ_o`` for an ``(M, 3)`` array of directions.
    incident : array_like (3,)
        Unit direction toward the light.
    sensor : EqualAreaSensor
    cells : array_like of int, optional
        Cells to integrate (default all).
    n_sub : int, optional
        Sub-points per cell side for a generic model (default 8).
    n_sub_body, n_sub_specular : int, optional
        For a :class:`SingleBounceModel`: sub-points for the body term (default 4) and
        the specular term (default :func:`specular_subpoints`; a lobe too narrow for it is
        integrated near its peak in the half-vector domain, :func:`specular_integrals`).

    Returns
    -------
    ndarray (n_cells,) or (len(cells),)
        Cosine-weighted integrals (dimensionless); their sum over all cells is the
        directional albedo.
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    if isinstance(model, SingleBounceModel):
        size = sensor.n_cells if cells is None else np.asarray(cells).size
        total = np.zeros(size)
        if model.has_specular:
            total += specular_integrals(model, incident, sensor, cells, n_sub=n_sub_specular)
        if model.body_factor > 0.0:
            total += integrate_cells(model.body_projected, incident, sensor, n_sub_body, cells)
        return total
    return integrate_cells(model.projected, incident, sensor, n_sub or DEFAULT_SUB, cells)


def specular_integrals(model: SingleBounceModel, incident, sensor: EqualAreaSensor, cells=None, n_sub=None,
                       n_azimuth=DEFAULT_AZIMUTH_NODES, n_radial=DEFAULT_RADIAL_NODES, peak=None) -> np.ndarray:
    """``∫_c f_s cos θ_o dω_o`` per cell (physics.md sec. 6-7).

    The sub-cell rule (``n_sub`` points, default ``MIN_SPECULAR_SUB``) everywhere
    except in the peak cells (:func:`~vcavity.analytic.peak_cells.peak_cells`), where
    the lobe is finer than that rule resolves (a lobe narrower than a cell, Beckmann
    alpha 1e-4 or Phong exponent 1e300; an anisotropic ridge; the wedge of any lobe at
    grazing incidence): those are integrated by rays in the half-vector domain
    (:func:`~vcavity.analytic.specular_peak.peak_integrals`).

    Parameters
    ----------
    model : SingleBounceModel
    incident : array_like (3,)
    sensor : EqualAreaSensor
    cells : array_like of int, optional
        Cells to integrate (default all).
    n_sub : int, optional
        Sub-points per cell side of the sub-cell rule.
    n_azimuth, n_radial : int
        Gauss-Legendre nodes per piece of the peak rays.
    peak : array_like of int, optional
        The peak cells (sorted; default :func:`~vcavity.analytic.peak_cells.peak_cells`).

    Returns
    -------
    ndarray (n_cells,) or (len(cells),)
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    wanted = np.arange(sensor.n_cells) if cells is None else np.asarray(cells, dtype=np.int64).ravel()
    out = np.zeros(wanted.size)
    if not model.has_specular:
        return out
    n_sub = n_sub or MIN_SPECULAR_SUB
    peak = peak_cells(model, incident, sensor) if peak is None else np.asarray(peak, dtype=np.int64)
    in_peak = np.isin(wanted, peak)
    if np.any(in_peak):
        values = peak_integrals(model, incident, sensor, peak, n_azimuth, n_radial)
        out[in_peak] = values[np.searchsorted(peak, wanted[in_peak])]
    if np.any(~in_peak):
        # V-cavity masking: G1_V(o, h) < G1_V(i, h) exactly where o_z < i_z (o.h = i.h, IL eq. 14),
        # a kink of the specular term on the circle z = i_z
        kink = float(incident[2]) if model.masking == "vcavity" else None
        out[~in_peak] = integrate_cells(model.specular_projected, incident, sensor, n_sub, wanted[~in_peak],
                                   kink_z=kink)
    return out


def cell_average(model, incident, sensor: EqualAreaSensor, cells=None, **options) -> np.ndarray:
    """Cell-averaged cosine-weighted BRDF ``(1/Ω⊥_c) ∫_c f cos θ_o dω_o`` in 1/sr.

    Directly comparable with a table's ``brdf`` (physics.md sec. 6); ``options`` as in
    :func:`cell_integrals`.
    """
    integrals = cell_integrals(model, incident, sensor, cells=cells, **options)
    projected = np.asarray(sensor.cell_projected_solid_angle)
    return integrals / (projected if cells is None else projected[np.asarray(cells)])


def expected_counts(model, incident, sensor: EqualAreaSensor, paths: int, **options) -> np.ndarray:
    """Expected number of paths per cell: ``N_paths ∫_c f cos θ_o dω_o`` (physics.md sec. 6)."""
    return float(paths) * cell_integrals(model, incident, sensor, **options)
