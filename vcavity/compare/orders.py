"""Compare one bounce order of a specular table with the every-order model
(``vcavity compare --order K``).

For tables of specular facets (mirror, conductor, interfaced Lambertian with ``kd = 0``)
:func:`vcavity.analytic.specular_orders.specular_orders` gives the exact expectation of
every order per cell (physics.md sec. 12-13), so order ``K`` (1, 2, ..., or ``0`` for
f_inf) of a simulated table is tested like f1 is against the single-bounce model: a
Pearson chi-square of the cell counts (expected count < 5 pooled, plus the complement
"not order K") and a z-test of the order's albedo, both at the Sidak-corrected level
``1 - (1 - significance)^(1/(2 n_directions))``.

The model is refined until its L1 error estimate is at most a tenth of the L1 difference
Monte-Carlo noise alone gives (so it adds at most ~1 % to the statistic's spread); the
report prints both. A cell the model's mesh gives exactly 0 while paths landed there (a
sliver of grooves between mesh vertices, ~1e-10 of the light: seen in 1e9-path tables)
is not the fail-safe "model expects nothing here" failure of the statistics: its paths
join the complement category, and the report says how many; more than
:data:`UNRESOLVED_SHARE` of the order's paths (+ 5) there fails. Other facets, deterministic tables and orders a table did not
simulate are refused with :class:`ModelNotApplicable` (a one-line "not applicable",
never a pass).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vcavity.analytic.single_bounce import ModelNotApplicable
from vcavity.analytic.specular_orders import DEFAULT_TOLERANCE, is_specular, specular_orders
from vcavity.analytic.statistics import (
    AlbedoTest,
    ChiSquareResult,
    albedo_z_test,
    binomial_mean_abs_deviation,
    pearson_chi_square,
    sidak_threshold,
)
from vcavity.compare.single_bounce import material_of_table, untestable_counts
from vcavity.compare.text import angle, fixed, fmt, verdict
from vcavity.io.schema import order_name
from vcavity.sensor.directions import incident_vector

#: The model's L1 error may be at most this share of the L1 difference noise alone gives.
MODEL_TO_NOISE = 0.1
#: Paths in cells the model's mesh gives exactly 0 may be at most this share of the order's
#: paths (plus 5): the mesh misses slivers of grooves of mass ~1e-10, not whole lobes.
UNRESOLVED_SHARE = 1e-5
#: A model whose albedo rounds to 1 or more (lossless facets) is shrunk to ``1 - ALBEDO_GAP``
#: for the fail-safe statistics (which fail any model predicting every path); at 1e9 paths
#: this moves 1e-3 of a path.
ALBEDO_GAP = 1e-12


@dataclass(frozen=True)
class OrderComparison:
    """One incident direction: order ``order`` of the table against the model."""

    theta_i: float
    phi_i: float
    paths: int
    table_albedo: float
    model_albedo: float
    model_error: float  # L1 error estimate of the model's cells, relative to its albedo
    noise_l1: float  # relative L1 difference of noise alone
    relative_l1: float
    quads: int
    chi_square: ChiSquareResult
    albedo_test: AlbedoTest
    unresolved_cells: int  # cells the model's mesh gives 0 where paths landed
    unresolved_paths: int  # the paths in them (counted in the complement category)
    passed: bool


@dataclass(frozen=True)
class OrdersReport:
    """All directions of a table, one order, against the every-order model."""

    path: str
    order: int
    material: dict
    significance: float
    per_test_level: float
    directions: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """True when both tests pass for every direction."""
        return all(d.passed for d in self.directions)


def _check_applicable(table, material, order: int) -> None:
    """Refuse (one line) what the every-order model cannot test."""
    if material.microsurface != "v-cavity":
        raise ModelNotApplicable(f"--order {order_name(order)}: not applicable to table {table.path}: the "
                                 f"every-order model is of V-cavities, this table's microsurface is "
                                 f"{material.microsurface}")
    if not is_specular(material):
        raise ModelNotApplicable(f"--order {order_name(order)}: not applicable to {material.facet} facets with "
                                 f"{dict(material.facet_params)}: the every-order model needs specular facets "
                                 "(mirror, conductor, interfaced_lambertian with kd = 0 and eta > 1)")
    if untestable_counts(table) is not None:
        raise ModelNotApplicable(f"--order {order_name(order)}: table {table.path} was made by the "
                                 f"{table.estimator} estimator: it holds no path counts to test "
                                 f"({untestable_counts(table)})")
    try:
        row = table.order_index(order)
    except ValueError as exc:
        raise ModelNotApplicable(str(exc)) from None
    if table.order_source is not None and table.order_source[row] != 0:
        raise ModelNotApplicable(f"--order {order_name(order)}: that order is analytic in table {table.path} "
                                 f"(estimator {table.estimator}): there is nothing simulated to test")


def compare_order(table, order: int, significance: float = 0.01, tolerance: float | None = None) -> OrdersReport:
    """Test order ``order`` (0: f_inf) of every direction of ``table`` against the model.

    Parameters
    ----------
    table : vcavity.io.table.Table
    order : int
        1 .. the table's ``max_order``, or 0 for f_inf.
    significance : float
        Family-wise false-alarm rate (Sidak over 2 tests per direction).
    tolerance : float, optional
        The model's tolerance (:func:`specular_orders`); default: a tenth of the noise.

    Raises
    ------
    ModelNotApplicable
        Facets that are not specular, a table without path counts, a missing or analytic order.
    """
    material = material_of_table(table)
    _check_applicable(table, material, order)
    simulation = table.config.get("simulation", {})
    max_order = int(simulation.get("max_order", max(int(k) for k in table.order)))
    max_bounces = int(table.attrs.get("max_bounces", simulation.get("max_bounces", 10_000)))
    track_all = bool(simulation.get("track_all_orders", True))
    level = sidak_threshold(significance, 2 * len(table.theta_i))
    report = OrdersReport(path=str(table.path), order=int(order), material=dict(table.material),
                          significance=significance, per_test_level=level)
    for j, (theta, phi) in enumerate(zip(table.theta_i, table.phi_i)):
        incident = incident_vector(float(theta), float(phi))
        paths = int(table.paths[j])
        observed = table.counts[j, table.order_index(order)].astype(np.float64)
        rows = [order - 1] if order >= 1 else list(range(max_order + (1 if track_all else 0)))
        model = specular_orders(material, incident, table.sensor, max_order, max_bounces, rows=rows,
                                tolerance=DEFAULT_TOLERANCE if tolerance is None else tolerance)
        p, err = model.order(order, beyond=track_all)
        noise = float(binomial_mean_abs_deviation(paths, p).sum() / max(paths * p.sum(), 1e-300))
        if tolerance is None and err.sum() > MODEL_TO_NOISE * noise * p.sum():
            model = specular_orders(material, incident, table.sensor, max_order, max_bounces, rows=rows,
                                    tolerance=MODEL_TO_NOISE * noise)
            p, err = model.order(order, beyond=track_all)
        albedo = float(p.sum())
        scale = min(1.0, (1.0 - ALBEDO_GAP) / albedo) if albedo > 0.0 else 1.0
        expected = paths * p * scale
        # cells the mesh gives exactly 0 (a discretised model cannot tell 0 from 1e-10, e.g. a
        # sliver of grooves between mesh vertices): their paths go to the complement category,
        # and more than UNRESOLVED_SHARE of the order's paths there (+ 5) is a failure
        unresolved = (expected == 0.0) & (observed > 0.0)
        stray = int(observed[unresolved].sum())
        chi = pearson_chi_square(observed[~unresolved], expected[~unresolved], paths)
        stray_ok = stray <= UNRESOLVED_SHARE * observed.sum() + 5
        # z-test of the order's total; for albedos near 1 its complement (the same z, and a
        # lossless model's complement 0 passes only when nothing is missing)
        total = int(observed.sum())
        albedo_test = (albedo_z_test(total, albedo * scale, paths) if albedo <= 0.5
                       else albedo_z_test(paths - total, max(0.0, 1.0 - albedo), paths))
        l1 = float(np.abs(observed - expected).sum() / max(expected.sum(), 1e-300))
        report.directions.append(OrderComparison(
            theta_i=float(theta), phi_i=float(phi), paths=paths, table_albedo=total / paths,
            model_albedo=albedo, model_error=float(err.sum() / max(albedo, 1e-300)), noise_l1=noise,
            relative_l1=l1, quads=model.quads, chi_square=chi, albedo_test=albedo_test,
            unresolved_cells=int(np.count_nonzero(unresolved)), unresolved_paths=stray,
            passed=chi.passed(level) and albedo_test.passed(level) and stray_ok))
    return report


def format_order_report(report: OrdersReport) -> str:
    """Human-readable text of an :class:`OrdersReport` (what ``vcavity compare --order`` prints)."""
    name = order_name(report.order)
    lines = [f"table {report.path}",
             f"material: {', '.join(f'{k}={v}' for k, v in report.material.items())}",
             f"model: every-order specular V-cavity (deterministic) vs {name}: chi-square over cells and albedo "
             f"z-test, family level {report.significance:g} (Sidak: {report.per_test_level:.3g} per test)"]
    level = report.per_test_level
    for d in report.directions:
        c, a = d.chi_square, d.albedo_test
        lines += [
            f"theta_i {angle(d.theta_i)} deg  phi_i {angle(d.phi_i)} deg  paths {d.paths:,}",
            f"  {name} albedo: table {fixed(d.table_albedo)}  model {fixed(d.model_albedo)}  z = {fmt(a.z)}  "
            f"p = {fmt(a.p_value)}  -> {a.verdict(level)}",
            f"  relative L1 {fmt(d.relative_l1)}  (noise alone: {fmt(d.noise_l1)}; model error estimate "
            f"{fmt(d.model_error)}, {d.quads} x {d.quads} mesh)",
            f"  chi2 {name} vs model: {fmt(c.statistic)} / {c.dof} dof = {fmt(c.statistic / c.dof)}  "
            f"p = {fmt(c.p_value)}  ({c.n_categories} categories, {c.pooled_cells} cells pooled; "
            f"largest cell deviation {fmt(c.max_abs_z)} sigma in cell {c.max_z_cell})  -> {c.verdict(level)}",
        ]
        if d.unresolved_cells:
            limit = UNRESOLVED_SHARE * d.table_albedo * d.paths + 5
            state = "within" if d.unresolved_paths <= limit else "FAIL: more than"
            lines.append(f"  {d.unresolved_paths:,} path(s) in {d.unresolved_cells} cell(s) the model's mesh gives 0 "
                         f"(counted with the complement; {state} {fmt(limit)} allowed)")
    lines.append(f"result: {verdict(report, name)}")
    return "\n".join(lines)


__all__ = ["compare_order", "format_order_report", "OrdersReport", "OrderComparison"]
