"""Compare a simulated table with the analytic single-bounce models (``vcavity compare``).

For each incident direction of a table:

- albedo of every order in the table, and of the model for the order(s) it describes
  (``f1`` for the single-bounce models, ``f1 + f2`` for Oren-Nayar);
- relative L1 difference over the hemisphere, ``Σ_c |n_c - e_c| / Σ_c e_c`` (the
  cosine-weighted cell integrals, physics.md sec. 6), next to the value Monte-Carlo noise
  alone gives (exact binomial mean absolute deviation per cell, summed);
- two tests of the ``f1`` counts against the single-bounce model of the table's
  microsurface (always that model: it is the exact expectation of ``f1``; V-cavity for
  V-groove tables, physics.md sec. 7, height-correlated Smith for Smith tables, sec. 15): a Pearson
  chi-square over cells (expected count < 5 pooled, plus the complementary "not f1"
  category; chi2/dof, p-value, the largest per-cell deviation in standard errors) and a
  z-test of the f1 albedo (the total count). Both are fail-safe
  (:mod:`vcavity.analytic.statistics`): a model that predicts NaN, no paths where paths
  landed, or an albedo >= 1 fails; a chi-square with fewer than two categories is
  "not testable", which is not a pass.

The comparison passes when both tests pass for every direction at the Sidak-corrected
level ``1 - (1 - significance)^(1/(2 n_directions))``, so the family-wise false-alarm
rate is ``significance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vcavity.analytic.cells import cell_integrals
from vcavity.analytic.exact_f1 import F1_MASKING
from vcavity.analytic.oren_nayar import OrenNayarModel
from vcavity.analytic.single_bounce import (
    DEFAULT_BODY_NODES,
    MAX_BODY_NODES,
    ModelNotApplicable,
    SingleBounceModel,
)
from vcavity.analytic.statistics import (
    AlbedoTest,
    ChiSquareResult,
    albedo_z_test,
    binomial_mean_abs_deviation,
    pearson_chi_square,
    sidak_threshold,
)
from vcavity.estimators import registry as estimators
from vcavity.material import ConfigError, Material
from vcavity.compare.text import angle, fixed, fmt, verdict
from vcavity.io.schema import order_name
from vcavity.sensor.directions import incident_vector

MODELS = ("vcavity", "smith", "smith-hc", "oren-nayar")
DEFAULT_SIGNIFICANCE = 0.01


@dataclass(frozen=True)
class DirectionComparison:
    """Comparison for one incident direction (see the module docstring)."""

    theta_i: float
    phi_i: float
    paths: int
    table_albedo: dict  # order -> albedo (0 = f_inf)
    model_orders: tuple  # orders the model describes, summed
    model_albedo: float
    table_model_albedo: float  # table albedo of those orders
    relative_l1: float
    noise_l1: float  # expected relative L1 from noise alone
    chi_square: ChiSquareResult
    albedo_test: AlbedoTest
    vcavity_f1_albedo: float
    passed: bool


@dataclass(frozen=True)
class ComparisonReport:
    """All directions of a table compared with one model."""

    path: str
    model: str
    material: dict
    significance: float
    per_test_level: float
    directions: list = field(default_factory=list)
    exact_model: str = "vcavity"  # the model the f1 tests use (EXACT_F1_MODEL of the microsurface)

    @property
    def passed(self) -> bool:
        """True when both f1 tests (against :attr:`exact_model`) pass for every direction."""
        return all(d.passed for d in self.directions)


def material_of_table(table) -> Material:
    """Rebuild and validate the :class:`~vcavity.material.Material` of a table.

    Format-v1 tables of mirror facets also stored ``kd = 0`` and ``eta = 1`` (fields
    every material carried then); those are dropped.

    Raises
    ------
    ModelNotApplicable
        When the stored material is not a valid material of this vcavity.
    """
    stored = dict(table.material)
    if stored.get("facet") == "mirror" and stored.get("kd") == 0.0 and stored.get("eta") == 1.0:
        del stored["kd"], stored["eta"]
    try:
        return Material.from_dict(stored, table="/material")
    except ConfigError as exc:
        raise ModelNotApplicable(f"material of table {table.path} not understood: {exc}") from None


def _orders_for(model: str) -> tuple:
    return (1, 2) if model == "oren-nayar" else (1,)


def build_model(material: Material, model: str, n_nodes: int = DEFAULT_BODY_NODES, lambda_fit: bool = False):
    """The analytic model object for ``model`` (one of :data:`MODELS`).

    Raises
    ------
    ModelNotApplicable
        If the model does not apply to the material, or ``n_nodes`` (``--nodes``) is
        outside ``[1, MAX_BODY_NODES]``.
    """
    if model not in MODELS:
        raise ValueError(f"model = {model!r}: accepted {', '.join(MODELS)}")
    if not 1 <= int(n_nodes) <= MAX_BODY_NODES:
        # 2 n^2 nodes over m: --nodes 100000 would allocate 75 GiB
        raise ModelNotApplicable(f"--nodes = {n_nodes}: must be in [1, {MAX_BODY_NODES}] (the body integral "
                                 f"uses 2 N^2 nodes: {MAX_BODY_NODES} is already {2 * MAX_BODY_NODES ** 2:,})")
    if model == "oren-nayar":
        return OrenNayarModel(material)
    if lambda_fit and material.distribution != "beckmann":
        raise ModelNotApplicable("--lambda-fit (Walter's fit, W eq. 27) exists for beckmann tables only")
    return SingleBounceModel(material, masking=model, lambda_fit=lambda_fit, n_nodes=n_nodes)


#: The exact expectation of each microsurface's f1 (what the chi-square tests use): the
#: V-groove walk's f1 is the V-cavity model, the Smith walk's the height-correlated Smith
#: model (physics.md sec. 7 and 15); the exact-f1 estimator's model is the same.
EXACT_F1_MODEL = F1_MASKING


def untestable_counts(table) -> str | None:
    """Why the table's counts are not path counts a multinomial test may read (its
    estimator's ``COUNTS_UNTESTABLE``), or None when they are."""
    module = estimators.find(table.estimator)
    if module is None:
        return f"an estimator this vcavity does not know ({', '.join(estimators.names())} are)"
    return module.COUNTS_UNTESTABLE


def compare_table(table, model: str | None = None, significance: float = DEFAULT_SIGNIFICANCE,
                  n_nodes: int = DEFAULT_BODY_NODES, lambda_fit: bool = False,
                  plots_dir=None) -> ComparisonReport:
    """Compare every incident direction of ``table`` with ``model``.

    Parameters
    ----------
    table : vcavity.io.table.Table
    model : str, optional
        One of :data:`MODELS`; default the exact f1 model of the table's microsurface
        (:data:`EXACT_F1_MODEL`). The f1 tests always use that one.
    significance : float
        Family-wise false-alarm rate of the f1 tests (Sidak over 2 tests per direction).
    n_nodes : int
        Body-integral control of the single-bounce models.
    lambda_fit : bool
        Beckmann Smith models: Walter's rational Lambda.
    plots_dir : path, optional
        Write one PNG per direction there (matplotlib, Agg), all at the end and each
        atomically; the folder (and missing ones above it) is created.

    Raises
    ------
    ModelNotApplicable
        Model not applicable to the table's material, a needed order missing, or a table
        whose estimator leaves no path counts to test (the paper estimator's weighted
        estimates, the exact estimator's models).
    PlotsNotWritten
        Writing the PNGs failed (a full disk, ...): none was written or replaced, and no
        folder or temporary file of this call is left behind.
    """
    # the chi-square and the albedo z-test below are multinomial: they read path counts
    untestable = untestable_counts(table)
    if untestable is not None:
        raise ModelNotApplicable(f"table {table.path} was made by the {table.estimator} estimator: {untestable}, "
                                 "and compare's tests need path counts; run with --estimator analog to validate "
                                 "the walk")
    material = material_of_table(table)
    exact = EXACT_F1_MODEL[material.microsurface]
    model = exact if model is None else model
    if model == "vcavity" and exact != "vcavity":
        raise ModelNotApplicable(f"--model vcavity: table {table.path} is of the {material.microsurface} "
                                 f"microsurface; its f1 model is {exact} (the V-cavity model describes V-grooves)")
    chosen = build_model(material, model, n_nodes, lambda_fit)
    reference = chosen if model == exact else build_model(material, exact, n_nodes)
    orders = _orders_for(model)
    order_rows = []
    for k in sorted(set(orders) | {1}):
        try:
            order_rows.append(table.order_index(k))
        except ValueError:
            raise ModelNotApplicable(
                f"table {table.path} has no order {k} (orders: {', '.join(map(str, table.order))})") from None
    sensor = table.sensor
    level = sidak_threshold(significance, 2 * len(table.theta_i))
    report = ComparisonReport(path=str(table.path), model=model, material=dict(table.material),
                              significance=significance, per_test_level=level, exact_model=exact)
    pngs = []  # (file name, bytes): written together at the end, or not at all
    for j, (theta, phi) in enumerate(zip(table.theta_i, table.phi_i)):
        i = incident_vector(float(theta), float(phi))
        paths = int(table.paths[j])
        f1_integrals = cell_integrals(reference, i, sensor)
        f1_counts = table.counts[j, table.order_index(1)]
        chi = pearson_chi_square(f1_counts, paths * f1_integrals, paths)
        albedo = albedo_z_test(int(f1_counts.sum()), float(np.sum(f1_integrals)), paths)
        model_integrals = f1_integrals if chosen is reference else cell_integrals(chosen, i, sensor)
        observed = sum(table.counts[j, table.order_index(k)].astype(np.float64) for k in orders)
        expected = paths * model_integrals
        l1 = float(np.sum(np.abs(observed - expected)) / max(np.sum(expected), 1e-300))
        # noise yardstick: binomial cells around the model (its exact expectation for the
        # V-cavity f1), around the observed frequencies otherwise
        p_cells = model_integrals if model == exact else observed / paths
        noise = binomial_mean_abs_deviation(paths, p_cells).sum() / max(np.sum(paths * p_cells), 1e-300)
        report.directions.append(DirectionComparison(
            theta_i=float(theta), phi_i=float(phi), paths=paths,
            table_albedo={int(k): float(table.albedo[j, n]) for n, k in enumerate(table.order)},
            model_orders=orders, model_albedo=float(np.sum(model_integrals)),
            table_model_albedo=float(observed.sum() / paths), relative_l1=l1, noise_l1=float(noise),
            chi_square=chi, albedo_test=albedo, vcavity_f1_albedo=float(np.sum(f1_integrals)),
            passed=chi.passed(level) and albedo.passed(level)))
        if plots_dir is not None:
            pngs.append(_plot_direction(
                table, j, observed / (paths * sensor.cell_projected_solid_angle),
                model_integrals / sensor.cell_projected_solid_angle,
                (f1_counts - paths * f1_integrals) / np.sqrt(np.maximum(paths * f1_integrals, 1.0)), model, orders))
    if plots_dir is not None:
        write_plots(Path(plots_dir), pngs)
    return report


class PlotsNotWritten(Exception):
    """``compare --plots``: the PNGs could not be written; none was, nothing is left behind.

    Attributes
    ----------
    reason : str
        What the system said (``No space left on device``).
    """

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


def write_plots(folder: Path, files) -> None:
    """Write ``files`` (pairs of name and bytes) into ``folder``: all of them or none.

    Each goes to a temporary file beside its destination (:mod:`vcavity.io.atomic`);
    once all are complete they are renamed into place. On a failure (a full disk) or a
    Ctrl-C the temporary files and the folders this call created are removed, and files
    already there are untouched.

    Raises
    ------
    PlotsNotWritten
        The system refused a write.
    """
    import os

    from vcavity.io import atomic

    created = []
    ancestor = folder
    while not ancestor.exists() and ancestor != ancestor.parent:
        created.append(ancestor)
        ancestor = ancestor.parent
    temporaries = []
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files:
            temporaries.append((atomic.create_temporary(folder / name), folder / name))
            atomic.write_bytes(temporaries[-1][0], data)
        for temporary, destination in temporaries:
            os.replace(temporary, destination)
    except BaseException as exc:
        for temporary, _ in temporaries:
            temporary.unlink(missing_ok=True)
        for made in created:  # deepest first; one that is not empty is not ours alone
            try:
                made.rmdir()
            except OSError:
                pass
        if isinstance(exc, OSError):
            raise PlotsNotWritten(exc.strerror or str(exc).splitlines()[0]) from None
        raise


def format_report(report: ComparisonReport) -> str:
    """Human-readable text of a :class:`ComparisonReport` (what ``vcavity compare`` prints)."""
    m = report.material
    lines = [f"table {report.path}",
             f"material: {', '.join(f'{k}={v}' for k, v in m.items())}",
             f"model: {report.model} vs {' + '.join(order_name(k) for k in _orders_for(report.model))}; "
             f"f1 vs {report.exact_model} model: chi-square over cells and albedo z-test, family level "
             f"{report.significance:g} (Sidak: {report.per_test_level:.3g} per test)"]
    level = report.per_test_level
    for d in report.directions:
        c, a = d.chi_square, d.albedo_test
        albedos = "  ".join(f"{order_name(k)} {fixed(v)}" for k, v in sorted(d.table_albedo.items()))
        ratio = d.relative_l1 / d.noise_l1 if d.noise_l1 > 0 else float("inf")
        lines += [
            f"theta_i {angle(d.theta_i)} deg  phi_i {angle(d.phi_i)} deg  paths {d.paths:,}",
            f"  table albedo: {albedos}",
            f"  {'+'.join(order_name(k) for k in d.model_orders)}: table {fixed(d.table_model_albedo)}  "
            f"model {fixed(d.model_albedo)}  ({report.model})",
            f"  relative L1 {fmt(d.relative_l1)}  (noise alone: {fmt(d.noise_l1)}, ratio {fmt(ratio)})",
            f"  chi2 f1 vs {report.exact_model}: {fmt(c.statistic)} / {c.dof} dof = {fmt(c.statistic / c.dof)}  "
            f"p = {fmt(c.p_value)}  ({c.n_categories} categories, {c.pooled_cells} cells pooled; "
            f"largest cell deviation {fmt(c.max_abs_z)} sigma in cell {c.max_z_cell})  -> {c.verdict(level)}",
            f"  f1 albedo: table {fixed(d.table_albedo.get(1, float('nan')))}  model {fixed(d.vcavity_f1_albedo)}  "
            f"z = {fmt(a.z)}  p = {fmt(a.p_value)}  -> {a.verdict(level)}",
        ]
    lines.append(f"result: {verdict(report, 'f1')}")
    return "\n".join(lines)


def _plot_direction(table, j, table_brdf, model_brdf, z, model, orders):
    """One PNG per direction: table, model and f1 deviation in sigma, as sensor images;
    returns its file name and its bytes."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = table.sensor.resolution
    theta = math.degrees(float(table.theta_i[j]))
    phi = math.degrees(float(table.phi_i[j]))
    label = " + ".join(order_name(k) for k in orders)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    top = float(max(np.max(table_brdf), np.max(model_brdf), 1e-300))
    for ax, data, title in ((axes[0], table_brdf, f"table {label}"), (axes[1], model_brdf, f"model {model}")):
        im = ax.imshow(data.reshape(n, n), origin="lower", extent=(-1, 1, -1, 1), vmin=0.0, vmax=top)
        ax.set_title(title)
        fig.colorbar(im, ax=ax, label="1/sr")
    im = axes[2].imshow(z.reshape(n, n), origin="lower", extent=(-1, 1, -1, 1), cmap="RdBu_r", vmin=-4, vmax=4)
    axes[2].set_title("f1 - V-cavity model (sigma)")
    fig.colorbar(im, ax=axes[2])
    for ax in axes:
        ax.set_xlabel("u (sensor square)")
        ax.set_ylabel("v")
    fig.suptitle(f"{Path(str(table.path)).name}: theta_i {fmt(theta)} deg, phi_i {fmt(phi)} deg")
    fig.tight_layout()
    # file names stay short for any stored angle (phi_i = 1e300 deg is a valid table)
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=90)
    plt.close(fig)
    return f"compare_{model}_theta{fmt(theta)}_phi{fmt(phi)}.png".replace("+", ""), png.getvalue()
