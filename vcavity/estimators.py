"""From integer counts to a BRDF table: the estimators and the mirror-symmetry fold.

Plain NumPy, no physics of the walk here (physics.md sec. 6 and 11). A run produces
integer counts per incident direction, order and sensor cell; this module turns them into
``brdf``, ``brdf_stderr`` and ``albedo`` (what the table stores), for

- ``analog``: every order simulated; ``brdf[c] = counts[c] / (N Ω⊥_c)`` with the binomial
  standard error ``sqrt(n (1 - n/N)) / (N Ω⊥_c)``;
- ``paper``: the IL paper's estimator (IL eq. 23, :mod:`vcavity.kernels.paper`): paths
  start on a facet and carry a weight ``w``, summed as integers ``q = w Q`` (stochastic
  rounding); ``brdf[c] = Σ q / (Q N Ω⊥_c)`` with the standard error of a mean of
  ``N`` per-path contributions, ``sqrt(Σ q^2 - (Σ q)^2 / N) / (Q N Ω⊥_c)``;
- ``exact``: no path at all, for specular facets only: every order is the cell average of
  the every-order model (physics.md sec. 12-13) and ``brdf_stderr`` its error estimate
  (:mod:`vcavity.simulate.exact`);
- ``exact-f1``: the first order is the exact cell-averaged V-cavity single-bounce model
  (its integrals ``I_c = ∫_c f1 cos θ_o dω_o`` and their quadrature error ``e_c`` come from
  :mod:`vcavity.analytic`), the walk bins only orders >= 2, and
  ``f_inf = I_c / Ω⊥_c + counts_inf[c] / (N Ω⊥_c)``; the quadrature error is added to the
  statistical one in quadrature: ``stderr = sqrt(n (1 - n/N) / N^2 + e_c^2) / Ω⊥_c``.

The **fold** uses the mirror symmetry of the BRDF about the plane of incidence (an
isotropic material, or an anisotropic one whose principal axes contain the plane): when
that plane is also a mirror line of the sensor grid, a cell and its mirror cell are one
region of twice the area, so their tabulated value is ``(n_c + n_c') / (2 N Ω⊥_c)`` and its
standard error is the binomial one of the merged count — about ``1/sqrt(2)`` of the
unfolded one. Cells on the plane are their own mirror and stay as they are. Raw counts
are never folded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vcavity.sensor.grid import EqualAreaSensor

ANALOG = "analog"
EXACT_F1 = "exact-f1"
PAPER = "paper"
EXACT = "exact"
#: Estimators ``[simulation] estimator`` accepts.
ESTIMATORS = (ANALOG, EXACT_F1, PAPER, EXACT)

#: ``order_source`` flags (CF flag_values / flag_meanings of the table).
SIMULATED = 0
ANALYTIC = 1
ANALYTIC_PLUS_SIMULATED = 2
ORDER_SOURCE_MEANINGS = "simulated analytic analytic_plus_simulated"


def grid_mirror_planes(isotropic: bool) -> float:
    """Spacing in degrees of the azimuths phi_i whose plane of incidence is a mirror
    plane of both the BRDF and the sensor grid.

    The concentric sensor grid is symmetric under the reflections of the square (lines at
    multiples of 45 deg, physics.md sec. 6); an isotropic BRDF is symmetric about every
    plane of incidence, an anisotropic one (axes along x and y) only about the planes
    phi_i = 0 and 90 deg (mod 180).
    """
    return 45.0 if isotropic else 90.0


def has_mirror_symmetry(phi_i_deg: float, isotropic: bool) -> bool:
    """Whether the table of incident azimuth ``phi_i_deg`` may be folded (see module doc)."""
    step = grid_mirror_planes(isotropic)
    return math.isfinite(phi_i_deg) and math.remainder(float(phi_i_deg), step) == 0.0


def mirror_cells(sensor: EqualAreaSensor, phi_i_deg: float) -> np.ndarray:
    """The mirror cell of every cell about the plane of incidence at azimuth ``phi_i_deg``.

    Parameters
    ----------
    sensor : EqualAreaSensor
    phi_i_deg : float
        A multiple of 45 degrees (the grid's mirror lines).

    Returns
    -------
    ndarray of int64 (n_cells,)
        ``mirror[c]`` is the cell whose region is the reflection of cell ``c``; an
        involution, ``mirror[c] == c`` for cells the plane cuts in half.

    Raises
    ------
    ValueError
        If ``phi_i_deg`` is not a multiple of 45 degrees.
    """
    steps = math.remainder(float(phi_i_deg), 180.0) / 45.0  # the line at phi and phi + 180
    if not (math.isfinite(steps) and steps == round(steps)):
        raise ValueError(f"phi_i_deg = {phi_i_deg!r}: the sensor grid has mirror lines only at "
                         "multiples of 45 degrees")
    n = sensor.resolution
    iy, ix = np.divmod(np.arange(n * n, dtype=np.int64), n)
    last = n - 1
    # In the square (u, v) the mirror line of azimuth phi is the line at angle phi
    # (the concentric map keeps the lines at multiples of 45 deg): reflect the indices.
    reflected = {0: (ix, last - iy),           # about phi = 0: v -> -v
                 1: (iy, ix),                  # about phi = 45: u <-> v
                 2: (last - ix, iy),           # about phi = 90: u -> -u
                 -1: (last - iy, last - ix),   # about phi = 135 (= -45): (u, v) -> (-v, -u)
                 -2: (last - ix, iy)}[int(round(steps))]
    return reflected[1] * n + reflected[0]


@dataclass(frozen=True)
class DirectionEstimate:
    """Tabulated values of one incident direction.

    Attributes
    ----------
    brdf, brdf_stderr : ndarray (n_orders, n_cells)
        Cell-averaged cosine-weighted BRDF and its standard error, 1/sr.
    albedo : ndarray (n_orders,)
        Directional albedo per order.
    """

    brdf: np.ndarray
    brdf_stderr: np.ndarray
    albedo: np.ndarray


def estimate_direction(counts, paths: int, orders, projected_solid_angle, mirror=None,
                       f1_integrals=None, f1_error=None) -> DirectionEstimate:
    """BRDF, standard error and albedo of one incident direction (see module doc).

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
        :func:`mirror_cells` to fold, or None.
    f1_integrals, f1_error : array_like (n_cells,), optional
        Exact-f1 estimator: ``∫_c f1 cos θ_o dω_o`` per cell and its quadrature error.

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
    return DirectionEstimate(brdf=energy / area, brdf_stderr=np.sqrt(variance) / area,
                             albedo=albedo)


def estimate_weighted(weights, squares, paths: int, scale: float, projected_solid_angle,
                      mirror=None) -> DirectionEstimate:
    """BRDF, standard error and albedo of one direction of a weighted (paper) run.

    Parameters
    ----------
    weights, squares : array_like of int (n_orders, n_cells)
        Per order and cell, ``Σ q`` and ``Σ q^2`` of the integer path weights ``q``.
    paths : int
        Paths started (> 0), zero-weight ones included.
    scale : float
        ``Q``: a path of weight ``w`` has ``q ≈ w Q``.
    projected_solid_angle : array_like (n_cells,)
    mirror : array_like of int (n_cells,), optional
        :func:`mirror_cells` to fold, or None.

    Returns
    -------
    DirectionEstimate
    """
    n = float(paths)
    area = np.asarray(projected_solid_angle, dtype=np.float64)
    first = np.asarray(weights, dtype=np.float64) / scale
    second = np.asarray(squares, dtype=np.float64) / (scale * scale)
    albedo = first.sum(axis=1) / n
    if mirror is not None:
        mirror = np.asarray(mirror, dtype=np.int64)
        pair = mirror != np.arange(mirror.size)
        first = first + np.where(pair, first[:, mirror], 0.0)
        second = second + np.where(pair, second[:, mirror], 0.0)
        area = np.where(pair, 2.0 * area, area)
    spread = np.sqrt(np.maximum(second - first * first / n, 0.0))
    return DirectionEstimate(brdf=first / (n * area), brdf_stderr=spread / (n * area), albedo=albedo)


def relative_error(estimate: DirectionEstimate, orders, projected_solid_angle) -> float:
    """Energy-weighted mean relative standard error of f_inf over the cells.

    ``Σ_c w_c (σ_c / f_c) / Σ_c w_c`` with the energy weights ``w_c = f_c Ω⊥_c``, that is
    ``Σ_c σ_c Ω⊥_c / Σ_c f_c Ω⊥_c``; inf while nothing has been seen.
    """
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
        Paths that left the surface (binned, and exact-f1's unbinned first-order exits).
    target : float
        The target relative error, > 0.

    Returns
    -------
    bool
    """
    return landed >= 0.5 / (target * target)


def order_source(orders, estimator: str) -> np.ndarray:
    """Per-order flag: ``SIMULATED``, ``ANALYTIC`` or ``ANALYTIC_PLUS_SIMULATED`` (int8)."""
    flags = np.full(len(orders), SIMULATED, dtype=np.int8)
    if estimator == EXACT:
        flags[:] = ANALYTIC
    elif estimator == EXACT_F1:
        for position, k in enumerate(orders):
            flags[position] = ANALYTIC if k == 1 else ANALYTIC_PLUS_SIMULATED if k == 0 else SIMULATED
    return flags


__all__ = ["ANALOG", "EXACT", "EXACT_F1", "ESTIMATORS", "PAPER", "DirectionEstimate", "error_estimate_exists",
           "estimate_direction", "estimate_weighted", "has_mirror_symmetry", "mirror_cells", "order_source", "relative_error"]
