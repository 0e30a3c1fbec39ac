"""Cell integrals of the V-cavity single-bounce model with an error estimate, refined to a
tolerance (physics.md sec. 6-7): the model side of the ``exact-f1`` estimator.

``f1_cell_integrals(material, incident, sensor, tolerance)`` returns per cell
``I_c = ∫_c f1(i, o) cos θ_o dω_o`` (what :func:`vcavity.analytic.cells.cell_integrals`
computes for ``SingleBounceModel(material)``, the exact expectation of the simulated f1
per path) and an estimate ``E_c`` of its quadrature error with ``E_c <= tolerance_c``.

Every estimate is the difference between a rule and a coarser one, reported as the error
of the finer (conservative where the rules converge, which the tests check against much
finer rules; docs/validation.md):

- body term (IL eq. 12): ``|B(n, s) - B(n/2, s)| + |B(n, s) - B(n, s/2)|`` for the
  ``n``-node integral over ``m`` and the ``s x s`` sub-cell rule in ``o``;
- specular term (W eq. 20) outside the peak cells: ``|S(s) - S(s/2)|``;
- specular term in the peak cells (:mod:`vcavity.analytic.specular_peak`): the azimuthal
  halving differences plus the change when the radial nodes are halved.

Cells whose estimate exceeds their tolerance are recomputed with the offending rule
doubled (only those cells), up to :data:`MAX_REFINE_NODES` nodes, :data:`MAX_SUB_BODY`
and :data:`MAX_SUB` sub-points, within :data:`MAX_BODY_WORK` and :data:`MAX_SPECULAR_WORK`;
what still exceeds it raises :class:`ModelNotApplicable`.
"""

from __future__ import annotations

import numpy as np

from vcavity.analytic.batches import check_stop
from vcavity.analytic.cells import DEFAULT_BODY_SUB, integrate_cells
from vcavity.analytic.quadrature import MIN_SPECULAR_SUB
from vcavity.analytic.single_bounce import ModelNotApplicable, SingleBounceModel
from vcavity.analytic.specular_peak import (
    DEFAULT_PEAK_TOLERANCE,
    DEFAULT_RADIAL_NODES,
    peak_integrals,
)
from vcavity.analytic.peak_cells import peak_cells
from vcavity.sensor.grid import EqualAreaSensor

#: Starting body-integral control: half the compare default (64), a quarter of its cost;
#: its error (about 4e-5 relative, O(n^-2) from the kinks of G2) is within the typical
#: tolerance (1e-1 of the statistical error of 1e7..1e9 paths) in most cells, and the
#: others are refined.
START_BODY_NODES = 32
#: Largest body-integral control reached by refinement (``2 n^2`` nodes over ``m``).
MAX_REFINE_NODES = 256
#: Largest sub-cell rules (points per cell side) reached by refinement: body, specular.
MAX_SUB_BODY = 32
MAX_SUB = 256
#: Bound on the refinement's body work, in (o point) x (m node) products: 25 x what the
#: figure 7(b) material at 60 deg needs refined to 1e9 paths' tolerance (its seconds:
#: docs/performance.md); a tolerance that needs more raises ModelNotApplicable.
MAX_BODY_WORK = 1e10
#: Bound on the refinement's specular sub-cell work, in points (as long as the body's bound).
MAX_SPECULAR_WORK = 2e8
#: Quantile of the relative differences that every cell's estimate reaches (:func:`guarded`).
GUARD_QUANTILE = 0.9
#: Round-off floor of an error estimate, relative to the largest cell (sums of up to
#: ~1e5 terms of ~1e-16 relative error each).
ROUNDOFF = 1e-12
#: Largest number of radial nodes per piece of the peak rays reached by refinement.
MAX_RADIAL = 32


#: The exact expectation of each microsurface's simulated f1, as a ``SingleBounceModel``
#: masking: the V-groove walk's f1 is the V-cavity model, the Smith walk's the
#: height-correlated Smith model (physics.md sec. 7 and 15).
F1_MASKING = {"v-cavity": "vcavity", "smith": "smith-hc"}


def f1_cell_integrals(material, incident, sensor: EqualAreaSensor, tolerance, *,
                      n_nodes: int = START_BODY_NODES, n_sub_body: int = DEFAULT_BODY_SUB,
                      n_sub_specular: int = MIN_SPECULAR_SUB, refine: bool = True, should_stop=None):
    """Per-cell integrals of the single-bounce model of the material's microsurface (the
    V-cavity model, or the height-correlated Smith model for a Smith microsurface:
    :data:`F1_MASKING`) and their error estimates.

    Parameters
    ----------
    material : vcavity.material.Material
        Validated material (any registered distribution and facet; a Smith microsurface's
        distribution must have a finite Smith Lambda).
    incident : array_like (3,)
        Unit direction toward the light, ``z > 0``.
    sensor : vcavity.sensor.grid.EqualAreaSensor
    tolerance : float or array_like (n_cells,)
        Absolute error allowed per cell, in the units of the integrals (dimensionless:
        a probability per path), >= 0; ``inf`` accepts the starting rules as they are.
    n_nodes, n_sub_body, n_sub_specular : int, keyword-only
        Starting rules: body nodes over ``m`` (``2 n^2`` of them), sub-cell points per side
        for the body and the specular term (each >= 2, since the estimate halves them).
    refine : bool, keyword-only
        Refine the cells above tolerance (default); ``False`` returns the starting rules'
        values and estimates unchanged.
    should_stop : callable, keyword-only
        Polled between the model's short compiled calls (:mod:`vcavity.analytic.batches`).

    Returns
    -------
    integrals : ndarray (n_cells,)
        ``∫_c f1 cos θ_o dω_o`` per cell (dimensionless, >= 0); their sum is the f1 albedo.
    error : ndarray (n_cells,)
        Estimated absolute quadrature error per cell, ``<= tolerance`` (after refinement).

    Raises
    ------
    ModelNotApplicable
        One line naming the cells, the error reached and the tolerance, when the
        refinement limits (:data:`MAX_REFINE_NODES`, :data:`MAX_SUB_BODY`, :data:`MAX_SUB`,
        :data:`MAX_RADIAL`, :data:`MAX_BODY_WORK`, :data:`MAX_SPECULAR_WORK`)
        do not bring every cell within tolerance.
    ValueError
        A tolerance that is negative, NaN or of the wrong shape; a starting rule below 2;
        an incident direction not in the upper hemisphere.
    vcavity.analytic.batches.ModelInterrupted
        ``should_stop`` returned True.
    """
    model = CellModel(material, incident, sensor, tolerance, n_nodes=n_nodes, n_sub_body=n_sub_body,
                      n_sub_specular=n_sub_specular, refine=refine, should_stop=should_stop)
    return model.values.copy(), model.error.copy()


def _tolerance_array(tolerance, sensor):
    tol = np.broadcast_to(np.asarray(tolerance, dtype=np.float64), (sensor.n_cells,)).copy() \
        if np.ndim(tolerance) == 0 or np.shape(tolerance) == (sensor.n_cells,) else None
    if tol is None:
        raise ValueError(f"tolerance: shape {np.shape(tolerance)}, expected a scalar or ({sensor.n_cells},)")
    if np.any(np.isnan(tol)) or np.any(tol < 0.0):
        raise ValueError("tolerance: must be >= 0 in every cell (no NaN)")
    return tol


class CellModel:
    """The model of :func:`f1_cell_integrals` kept with its rules, so that it can be refined
    further to a tighter tolerance without recomputing what is done (the exact-f1 estimator
    refines the pre-run model once the counts are known, :class:`vcavity.estimators.exact_f1.F1Models`).

    Parameters are those of :func:`f1_cell_integrals`; ``values`` and ``error`` (arrays of
    ``n_cells``) are its two results, updated by :meth:`refine_to`.
    """

    def __init__(self, material, incident, sensor: EqualAreaSensor, tolerance, *,
                 n_nodes: int = START_BODY_NODES, n_sub_body: int = DEFAULT_BODY_SUB,
                 n_sub_specular: int = MIN_SPECULAR_SUB, refine: bool = True, should_stop=None):
        incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
        if not incident[2] > 0.0:
            raise ValueError(f"incident = {incident.tolist()}: must point into the upper hemisphere (z > 0)")
        tol = _tolerance_array(tolerance, sensor)
        for name, value in (("n_nodes", n_nodes), ("n_sub_body", n_sub_body), ("n_sub_specular", n_sub_specular)):
            if int(value) < 2:
                raise ValueError(f"{name} = {value}: must be >= 2 (the error estimate halves it)")
        self.sensor = sensor
        self.masking = F1_MASKING[material.microsurface]
        model = SingleBounceModel(material, masking=self.masking, n_nodes=int(n_nodes))
        self.parts = []
        if model.has_specular:
            self.parts.append(_Specular(model, incident, sensor, int(n_sub_specular), tol, should_stop))
        if model.body_factor > 0.0:
            self.parts.append(_Body(material, model, incident, sensor, int(n_nodes), int(n_sub_body), should_stop))
        self.values, self.error = _total(self.parts, sensor)
        if refine:
            self._refine(tol)

    def refine_to(self, tolerance, should_stop=None) -> None:
        """Refine the cells whose error exceeds ``tolerance`` (scalar or per cell), starting
        from the rules reached so far; each call may spend the work bounds afresh.
        ``should_stop`` is polled as in :func:`f1_cell_integrals`.

        Raises
        ------
        ModelNotApplicable
            As :func:`f1_cell_integrals`; ``values`` and ``error`` then hold the finest
            rules reached (still a valid result with its error).
        vcavity.analytic.batches.ModelInterrupted
            ``should_stop`` returned True (the model is then half-refined: not to be used).
        """
        tol = _tolerance_array(tolerance, self.sensor)
        for part in self.parts:
            part.should_stop = should_stop
            part.work = 0.0
            part.tighten(tol)
        self.values, self.error = _total(self.parts, self.sensor)
        self._refine(tol)

    def _refine(self, tol):
        parts, sensor = self.parts, self.sensor
        while True:
            over = np.flatnonzero(self.error > tol)
            if over.size == 0:
                return
            # a component is refined in a cell when it alone uses more than its share
            share = tol[over] / max(len(parts), 1)
            progressed = False
            for part in parts:
                check_stop(part.should_stop)
                progressed |= part.refine(over, part.errors_at(over) > share)
            self.values, self.error = _total(parts, sensor)
            if not progressed:
                over = np.flatnonzero(self.error > tol)
                worst = over[np.argmax(self.error[over] - tol[over])]
                raise ModelNotApplicable(
                    f"exact f1: the {_MODEL_NAMES[self.masking]} "
                    f"model's quadrature error stays above the tolerance in {over.size} "
                    f"of {sensor.n_cells} cells (cell {worst}: {self.error[worst]:.3g} > {tol[worst]:.3g}) at the "
                    f"finest rules within bounded cost (body: {MAX_REFINE_NODES} nodes, {MAX_SUB_BODY} x "
                    f"{MAX_SUB_BODY} points per cell, {MAX_BODY_WORK:.0e} node-points; specular: {MAX_SUB} x "
                    f"{MAX_SUB} points, {MAX_SPECULAR_WORK:.0e} points, {MAX_RADIAL} radial nodes)")


_MODEL_NAMES = {"vcavity": "V-cavity", "smith-hc": "height-correlated Smith", "smith": "Smith"}


def _total(parts, sensor):
    """Sum of the parts' values and errors; the error is at least the round-off of the sums
    (:data:`ROUNDOFF` of the largest cell), so no cell reports an exact 0."""
    values = sum((p.value for p in parts), np.zeros(sensor.n_cells))
    error = sum((p.error for p in parts), np.zeros(sensor.n_cells))
    return values, np.maximum(error, ROUNDOFF * float(np.max(np.abs(values), initial=0.0)))


def guarded(difference, value, sensor, cells=None):
    """A per-cell error estimate from ``|fine - coarse|`` that an accidental agreement of
    the two rules in one cell cannot make small.

    The quadrature error of the body integral over ``m`` and of the sub-cell rules varies
    erratically from cell to cell (the kinks of G2, IL eq. 14, fall between the nodes
    differently in each cell), so in some cells two rules agree by chance far better than
    either is right. Measured at a forced coarse rule against rules 8-16 x finer, the raw
    difference fell below the actual error in up to a third of the cells, by up to 50 x
    (docs/validation.md). The estimate is therefore the larger of the largest difference
    over the cell and its 8 neighbours and :data:`GUARD_QUANTILE` of the relative
    differences over all cells times the cell's value.

    Parameters
    ----------
    difference, value : ndarray (n_cells,) or (len(cells),)
    sensor : EqualAreaSensor
    cells : array_like of int, optional
        The cells the arrays describe (default all); the neighbourhood is taken among them.
    """
    n = sensor.resolution
    cells = np.arange(sensor.n_cells) if cells is None else np.asarray(cells, dtype=np.int64)
    grid = np.zeros((n, n))
    grid.flat[cells] = difference
    padded = np.pad(grid, 1)
    neighbourhood = np.max([padded[1 + dy:n + 1 + dy, 1 + dx:n + 1 + dx] for dy in (-1, 0, 1) for dx in (-1, 0, 1)],
                           axis=0).flat[cells]
    magnitude = np.abs(value)
    significant = magnitude > 1e-6 * float(np.max(magnitude, initial=0.0))
    relative = 0.0
    if np.any(significant):
        relative = float(np.quantile(difference[significant] / magnitude[significant], GUARD_QUANTILE))
    return np.maximum(neighbourhood, relative * magnitude)


class _Body:
    """Body term per cell at a node count and sub-cell rule, with its two estimates."""

    def __init__(self, material, model, incident, sensor, n_nodes, n_sub, should_stop=None):
        self.material, self.incident, self.sensor = material, incident, sensor
        self.should_stop = should_stop
        self.masking = model.masking
        self.models = {n_nodes: model}
        self.n_nodes = np.full(sensor.n_cells, n_nodes)
        self.n_sub = np.full(sensor.n_cells, n_sub)
        self.work = 0.0
        self.value = self._body(n_nodes, n_sub, None)
        self.error_nodes = guarded(np.abs(self.value - self._body(n_nodes // 2, n_sub, None)), self.value, sensor)
        self.error_sub = guarded(np.abs(self.value - self._body(n_nodes, n_sub // 2, None, coarse=True)),
                                 self.value, sensor)

    @property
    def error(self):
        return self.error_nodes + self.error_sub

    def errors_at(self, cells):
        return self.error[cells]

    def tighten(self, tol):
        """Nothing to redo for a new tolerance: the body's rules depend on none (refine does it)."""

    def _model(self, n_nodes):
        if n_nodes not in self.models:
            self.models[n_nodes] = SingleBounceModel(self.material, masking=self.masking, n_nodes=n_nodes)
        return self.models[n_nodes]

    def _body(self, n_nodes, n_sub, cells, coarse=False):
        """Body integrals; ``coarse`` halves the minimum rules of the hard cells too."""
        model = self._model(n_nodes)
        # a point costs one term per node over m (2 n^2 of them): the batches are sized by it
        return integrate_cells(model.body_projected, self.incident, self.sensor, n_sub, cells,
                               hard_sub=4 if coarse else 8, corner_sub=8 if coarse else 16,
                               point_cost=2 * n_nodes * n_nodes, should_stop=self.should_stop)

    def refine(self, cells, wanted):
        """Double the larger-error rule of the ``wanted`` cells; False when none can be."""
        cells = cells[wanted]
        progressed = False
        # the rule with the larger error, or the other one when that is at its limit
        can_nodes = self.n_nodes[cells] < MAX_REFINE_NODES
        can_sub = self.n_sub[cells] < MAX_SUB_BODY
        prefer_nodes = self.error_nodes[cells] >= self.error_sub[cells]
        by_nodes = cells[can_nodes & (prefer_nodes | ~can_sub)]
        by_sub = cells[can_sub & ~(can_nodes & (prefer_nodes | ~can_sub))]
        work = float(np.sum(2.0 * (2 * self.n_nodes[by_nodes]) ** 2 * self.n_sub[by_nodes] ** 2)
                     + np.sum(2.0 * self.n_nodes[by_sub] ** 2 * (2 * self.n_sub[by_sub]) ** 2))
        if self.work + work > MAX_BODY_WORK:
            return False
        self.work += work
        for n in np.unique(self.n_nodes[by_nodes]):
            group = by_nodes[self.n_nodes[by_nodes] == n]
            for s in np.unique(self.n_sub[group]):
                chosen = group[self.n_sub[group] == s]
                finer = self._body(2 * n, s, chosen)
                self.error_nodes[chosen] = guarded(np.abs(finer - self.value[chosen]), finer, self.sensor, chosen)
                self.value[chosen] = finer
                self.n_nodes[chosen] = 2 * n
                progressed = True
        for s in np.unique(self.n_sub[by_sub]):
            group = by_sub[self.n_sub[by_sub] == s]
            for n in np.unique(self.n_nodes[group]):
                chosen = group[self.n_nodes[group] == n]
                finer = self._body(n, 2 * s, chosen)
                self.error_sub[chosen] = guarded(np.abs(finer - self.value[chosen]), finer, self.sensor, chosen)
                self.value[chosen] = finer
                self.n_sub[chosen] = 2 * s
                progressed = True
        return progressed


class _Specular:
    """Specular term: sub-cell rule outside the peak cells, peak rays inside."""

    def __init__(self, model, incident, sensor, n_sub, tol, should_stop=None):
        self.model, self.incident, self.sensor = model, incident, sensor
        self.should_stop = should_stop
        self.peak = peak_cells(model, incident, sensor)
        self.value = np.zeros(sensor.n_cells)
        self.error = np.zeros(sensor.n_cells)
        self.n_sub = np.full(sensor.n_cells, n_sub)
        self.work = 0.0
        rest = np.setdiff1d(np.arange(sensor.n_cells), self.peak)
        if rest.size:
            self.value[rest] = self._plain(n_sub, rest)
            self.error[rest] = guarded(np.abs(self.value[rest] - self._plain(n_sub // 2, rest, coarse=True)),
                                       self.value[rest], sensor, rest)
        self.n_radial = DEFAULT_RADIAL_NODES
        self.peak_tolerance = DEFAULT_PEAK_TOLERANCE
        if self.peak.size:
            self.peak_tolerance = min(DEFAULT_PEAK_TOLERANCE, 0.25 * float(np.min(tol[self.peak])))
            self._peak()

    def errors_at(self, cells):
        return self.error[cells]

    def _plain(self, n_sub, cells, coarse=False):
        """Sub-cell rule of the specular term; ``coarse`` halves the hard cells' minimum rules."""
        kink = float(self.incident[2]) if self.model.masking == "vcavity" else None
        return integrate_cells(self.model.specular_projected, self.incident, self.sensor, n_sub, cells, kink_z=kink,
                               hard_sub=4 if coarse else 8, corner_sub=8 if coarse else 16,
                               should_stop=self.should_stop)

    def tighten(self, tol):
        """A tighter tolerance in a peak cell: recompute the peak rays to it (as a model
        built for it from the start would)."""
        if self.peak.size:
            wanted = min(DEFAULT_PEAK_TOLERANCE, 0.25 * float(np.min(tol[self.peak])))
            if wanted < self.peak_tolerance:
                self.peak_tolerance = wanted
                self._peak()

    def _peak(self):
        self.value[self.peak], self.error[self.peak] = peak_integrals(
            self.model, self.incident, self.sensor, self.peak, n_radial=self.n_radial,
            tolerance=max(self.peak_tolerance, 1e-300), with_error=True, should_stop=self.should_stop)

    def refine(self, cells, wanted):
        """Double the sub-cell rule of the wanted plain cells; refine the peak rays."""
        cells = cells[wanted]
        progressed = False
        in_peak = np.isin(cells, self.peak)
        if np.any(in_peak) and self.n_radial < MAX_RADIAL:
            self.n_radial *= 2
            self.peak_tolerance = max(0.1 * self.peak_tolerance, 1e-15)
            self._peak()
            progressed = True
        plain = cells[~in_peak]
        plain = plain[self.n_sub[plain] < MAX_SUB]
        work = float(np.sum((2.0 * self.n_sub[plain]) ** 2))
        if self.work + work > MAX_SPECULAR_WORK:
            return progressed
        self.work += work
        for s in np.unique(self.n_sub[plain]):
            chosen = plain[self.n_sub[plain] == s]
            finer = self._plain(2 * s, chosen)
            self.error[chosen] = guarded(np.abs(finer - self.value[chosen]), finer, self.sensor, chosen)
            self.value[chosen] = finer
            self.n_sub[chosen] = 2 * s
            progressed = True
        return progressed


def compile_model(material) -> None:
    """Compile (or load from the cache) the compiled functions a :class:`CellModel` of
    ``material`` calls, on a sensor of 2 x 2 cells and the coarsest rules: what a run does
    before its models, so that their time is the model's own (the compile's is reported
    apart). The peak rays (:mod:`vcavity.analytic.specular_peak`) are compiled whenever
    the facet has a specular term, whether or not this material's lobe needs them."""
    sensor = EqualAreaSensor(2)
    incident = np.array([0.6, 0.0, 0.8])
    model = SingleBounceModel(material, masking=F1_MASKING[material.microsurface], n_nodes=2)
    cells = np.arange(sensor.n_cells)
    if model.has_specular:
        peak_cells(model, incident, sensor)
        integrate_cells(model.specular_projected, incident, sensor, 2, cells, kink_z=float(incident[2]))
        peak_integrals(model, incident, sensor, cells[:1], n_azimuth=2, n_radial=2, tolerance=np.inf,
                       with_error=True)
    if model.body_factor > 0.0:
        integrate_cells(model.body_projected, incident, sensor, 2, cells)


__all__ = ["F1_MASKING", "f1_cell_integrals", "CellModel", "compile_model", "START_BODY_NODES", "MAX_REFINE_NODES", "MAX_SUB_BODY", "MAX_SUB", "MAX_RADIAL",
           "MAX_BODY_WORK", "MAX_SPECULAR_WORK", "guarded"]
