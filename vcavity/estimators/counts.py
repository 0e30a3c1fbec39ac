"""What the estimators share: path counts as a BRDF, the mirror fold, the error of f_inf.

Plain NumPy, no physics of the walk here (physics.md sec. 6 and 11). For ``N`` paths of a
direction and ``n_c`` of them leaving through cell ``c`` with some order, the cell's
cosine-weighted BRDF is ``n_c / (N Ω⊥_c)`` with the binomial standard error
``sqrt(n_c (1 - n_c/N)) / (N Ω⊥_c)`` (:func:`binomial`).

The **fold** uses the mirror symmetry of the BRDF about the plane of incidence (an
isotropic material, or an anisotropic one whose principal axes contain the plane): when
that plane is also a mirror line of the sensor grid (:mod:`vcavity.sensor.mirror`), a cell
and its mirror cell are one region of twice the area, so their tabulated value is
``(n_c + n_c') / (2 N Ω⊥_c)`` and its standard error is the binomial one of the merged
count — about ``1/sqrt(2)`` of the unfolded one. Cells on the plane are their own mirror
and stay as they are. Raw counts are never folded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vcavity.sensor.mirror import mirror_cells

#: ``order_source`` flags (the table's CF flag_values; meanings in :mod:`vcavity.io.schema`).
SIMULATED = 0
ANALYTIC = 1
ANALYTIC_PLUS_SIMULATED = 2

@dataclass(frozen=True)
class DirectionEstimate:
    """Tabulated values of one incident direction.

    Attributes
    ----------
    brdf, brdf_stderr : ndarray (n_orders, n_cells)
        Cell-averaged cosine-weighted BRDF and its standard error, 1/sr.
    albedo : ndarray (n_orders,)
        Directional albedo per order.
    folded : bool
        Whether mirror cells were averaged (the table's ``folded``).
    """

    brdf: np.ndarray
    brdf_stderr: np.ndarray
    albedo: np.ndarray
    folded: bool = False


def table_counts(slots, track_all_orders: bool) -> np.ndarray:
    """The order axis of a table from a walk's order slots (slot 0 = beyond max_order):
    0 = every order (f_inf), then 1..K; without f_inf only 1..K."""
    if track_all_orders:
        return np.concatenate([slots.sum(axis=0, keepdims=True), slots[1:]], axis=0)
    return slots[1:].copy()


def mirror_of(config, sensor, direction: int):
    """:func:`vcavity.sensor.mirror.mirror_cells` of direction ``direction`` when its table
    folds (``config.folds``), else None."""
    d = config.incidence[direction]
    return mirror_cells(sensor, d.phi_i_deg) if config.folds(d) else None


def binomial(counts, paths: int, orders, projected_solid_angle, mirror=None, f1_integrals=None,
             f1_error=None) -> DirectionEstimate:
    """BRDF, standard error and albedo of one direction from path counts (see module doc).

    Parameters
    ----------
    counts : array_like of int (n_orders, n_cells)
        Paths per order (``orders``) and cell; with ``f1_integrals`` the row of order 1
        is not used (the walk did not bin it) and order 0 holds the binned orders >= 2.
    paths : int
        Paths simulated (> 0).
    orders : sequence of int
        The order axis: ``1..K`` or ``0, 1..K``.
    projected_solid_angle : array_like (n_cells,)
        ``Ω⊥_c`` of each cell, sr.
    mirror : array_like of int (n_cells,), optional
        :func:`vcavity.sensor.mirror.mirror_cells` to fold, or None.
    f1_integrals, f1_error : array_like (n_cells,), optional
        The exact-f1 estimator's first order: ``∫_c f1 cos θ_o dω_o`` per cell and its
        quadrature error (:mod:`vcavity.estimators.exact_f1`): ``f1 = I_c / Ω⊥_c``,
        ``f_inf = I_c / Ω⊥_c + n_inf,c / (N Ω⊥_c)``, and the quadrature error is added to
        the statistical one in quadrature.

    Returns
    -------
    DirectionEstimate
    """
    counts = np.asarray(counts)
    orders = list(orders)
    n = float(paths)
    area = np.asarray(projected_solid_angle, dtype=np.float64)
    merged = counts.astype(np.float64)
    model = None if f1_integrals is None else np.asarray(f1_integrals, dtype=np.float64)
    model_error = None if f1_error is None else np.asarray(f1_error, dtype=np.float64)
    if mirror is not None:
        mirror = np.asarray(mirror, dtype=np.int64)
        pair = mirror != np.arange(mirror.size)
        merged = merged + np.where(pair, merged[:, mirror], 0.0)
        area = np.where(pair, 2.0 * area, area)
        if model is not None:
            model = model + np.where(pair, model[mirror], 0.0)
            model_error = model_error + np.where(pair, model_error[mirror], 0.0)  # bound, not RMS
    energy = merged / n  # ∫ over the (merged) region of f cos θ dω
    variance = merged * (1.0 - merged / n) / (n * n)
    albedo = counts.sum(axis=1) / n
    if model is not None:
        first = orders.index(1)
        energy[first] = model
        variance[first] = model_error * model_error
        albedo[first] = float(np.sum(f1_integrals))
        if 0 in orders:
            energy[orders.index(0)] += model
            variance[orders.index(0)] += model_error * model_error
            albedo[orders.index(0)] += albedo[first]
    return DirectionEstimate(brdf=energy / area, brdf_stderr=np.sqrt(variance) / area, albedo=albedo,
                             folded=mirror is not None)


def path_fractions(stats, names, paths: int) -> np.ndarray:
    """Absorbed, truncated and degenerate paths of a direction as fractions of its ``paths``.

    ``stats`` holds the columns ``names`` (an estimator's ``STATS``)."""
    columns = [list(names).index(name) for name in ("absorbed", "truncated", "degenerate")]
    return np.asarray(stats, dtype=np.int64)[columns] / np.float64(paths)


def binomial_albedo_stderr(fraction, paths):
    """``sqrt(p (1 - p) / N)`` of albedos that are fractions ``p`` of ``N`` independent paths
    (NaN where ``N`` is 0: a sweep point not done)."""
    paths = np.asarray(paths, dtype=np.float64)
    paths = np.where(paths > 0, paths, np.nan)
    fraction = np.asarray(fraction, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(np.clip(fraction * (1.0 - fraction), 0.0, None) / paths)


def relative_error(estimate: DirectionEstimate, orders, projected_solid_angle) -> float:
    """Energy-weighted mean relative standard error of f_inf over the cells.

    ``Σ_c w_c (σ_c / f_c) / Σ_c w_c`` with the energy weights ``w_c = f_c Ω⊥_c``, that is
    ``Σ_c σ_c Ω⊥_c / Σ_c f_c Ω⊥_c``; inf while nothing has been seen, NaN without f_inf.
    """
    if 0 not in list(orders):
        return math.nan
    row = list(orders).index(0)
    area = np.asarray(projected_solid_angle, dtype=np.float64)
    total = float(np.sum(estimate.brdf[row] * area))
    if not total > 0.0:
        return math.inf
    return float(np.sum(estimate.brdf_stderr[row] * area)) / total


def error_estimate_exists(landed: int, target: float) -> bool:
    """Whether ``landed`` paths are enough for a relative error of f_inf to reach ``target``.

    The stop rule's measure (:func:`relative_error`) comes from binomial estimates
    ``sqrt(n_c (1 - n_c/N))``, which are 0, not small, when a few paths land (one path in
    one cell of one path traced: error 0). With ``n = Σ_c n_c`` landed paths and no cell
    holding more than half the paths, ``Σ_c sqrt(n_c (1 - n_c/N)) >= sqrt(n/2)``
    (``sqrt`` is subadditive), so an honest estimate of at most ``E`` needs ``n >= 1 / (2 E^2)``:
    below that the target counts as not reached (a non-degenerate run never stops
    earlier than that anyway, so the rule changes no such run).

    Parameters
    ----------
    landed : int
        Paths that left the surface (an estimator's ``landed``).
    target : float
        The target relative error, > 0.

    Returns
    -------
    bool
    """
    return landed >= 0.5 / (target * target)


__all__ = ["ANALYTIC", "ANALYTIC_PLUS_SIMULATED", "SIMULATED", "DirectionEstimate", "binomial", "binomial_albedo_stderr",
           "error_estimate_exists", "mirror_of", "path_fractions", "relative_error", "table_counts"]
