"""The ``exact`` estimator: a whole table of a specular V-cavity without tracing a path.

For mirror, conductor and ``kd = 0`` dielectric facets every order per cell is the
deterministic every-order model (:func:`vcavity.analytic.specular_orders.specular_orders`,
physics.md sec. 12-13). A run with ``estimator = "exact"`` tabulates it for every
incident direction: ``brdf = P_k(c) / Ω⊥_c``, ``brdf_stderr`` = the model's error
estimate ``/ Ω⊥_c`` (not a statistical error: the table is deterministic, its
``order_source`` says *analytic* for every order and the root attribute
``deterministic`` is 1), ``counts`` and ``paths`` are 0, and the absorbed and truncated
shares are the model's. The tolerance is ``[simulation] target_error`` when given, else
:data:`vcavity.analytic.specular_orders.DEFAULT_TOLERANCE`: the L1 error estimate of all
orders relative to what exits, which bounds the energy-weighted relative error of f_inf.
"""

from __future__ import annotations

import numpy as np

from vcavity.estimators import paper
from vcavity.estimators.counts import ANALYTIC, DirectionEstimate
from vcavity.estimators.models import DirectionModels
from vcavity.parameters import fail

NAME = "exact"
DESCRIPTION = ("specular facets only (mirror, conductor, kd = 0 dielectric): every order from the "
               "deterministic model, no path traced, brdf_stderr = the model's error estimate")
FIRST_BINNED_ORDER = 1
TALLIES = ()
STATS = ()
COUNTS_UNTESTABLE = "it traces no path: every order is the deterministic model"
STDERR_RULE = ("not available: the sweep stores no albedo error for estimator 'exact' (a deterministic "
               "model; its error estimate is per cell)")


def walk(material) -> None:
    """None: the model is the table."""
    return None


def check(config) -> None:
    """V-cavities with specular facets; ``max_paths`` does not apply (no path is traced)."""
    from vcavity.facet import registry as facets

    paper.check(config, NAME)  # the same microsurface rule: the models are of V-grooves
    material = config.material
    if not facets.is_specular(material.facet, material.facet_params):
        fail("simulation.estimator", NAME, "is for specular facets only (mirror, conductor, interfaced_lambertian "
             "with kd = 0 and eta > 1), whose every order has a deterministic model; this material is "
             f"{material.facet} with {dict(material.facet_params)}: use 'analog', 'exact-f1' or 'paper'")
    if config.max_paths is not None:
        fail("simulation.max_paths", config.max_paths, "does not apply to the exact estimator (it traces no "
             "path; simulation.target_error is its model's tolerance)")


def models(config, sensor) -> "ExactModels":
    """The every-order model of each direction (:class:`ExactModels`)."""
    return ExactModels(config, sensor)


def estimate(j: int, tally, paths: int, config, sensor, models) -> DirectionEstimate:
    """Direction ``j`` from its model: ``P_k(c) / Ω⊥_c`` and the error estimate ``/ Ω⊥_c``."""
    area = sensor.cell_projected_solid_angle
    orders = config.orders
    brdf = np.zeros((len(orders), sensor.n_cells))
    stderr = np.zeros_like(brdf)
    model = models.models[j]
    for position, k in enumerate(orders):
        values, errors = model.order(k, beyond=config.track_all_orders)
        brdf[position], stderr[position] = values / area, errors / area
    return DirectionEstimate(brdf=brdf, brdf_stderr=stderr, albedo=np.einsum("kc,c->k", brdf, area))


def lost_fractions(j: int, stats, paths: int, models) -> np.ndarray:
    """The model's absorbed and truncated shares (without f_inf, the orders beyond K are
    stopped after K bounces, as in the walk: they count as truncated); nothing degenerates."""
    model = models.models[j]
    beyond = 0.0 if models.config.track_all_orders else float(model.integrals[model.max_order].sum())
    return np.array([model.absorbed, model.truncated + beyond, 0.0])


def landed(tally, stats) -> int:
    """No path is traced."""
    return 0


def order_source(orders) -> np.ndarray:
    """Every order analytic."""
    return np.full(len(orders), ANALYTIC, dtype=np.int8)


def albedo_stderr(order: int, value, value_f1, paths):
    """None: a sweep keeps no per-direction model error of the albedo."""
    return None


class ExactModels(DirectionModels):
    """The every-order model of each incident direction of ``config`` (a validated run with
    ``estimator = "exact"``: specular facets): :class:`SpecularOrders
    <vcavity.analytic.specular_orders.SpecularOrders>` per direction, to :attr:`tolerance`."""

    @property
    def tolerance(self) -> float:
        """The model's tolerance: ``target_error`` when given, else the model's default."""
        from vcavity.analytic.specular_orders import DEFAULT_TOLERANCE

        return self.config.target_error if self.config.target_error is not None else DEFAULT_TOLERANCE

    CODE = "every-order model"

    def compile_code(self) -> None:
        """Compile the every-order model for the run's material (:func:`compile_model
        <vcavity.analytic.specular_orders.compile_model>`)."""
        from vcavity.analytic.specular_orders import compile_model

        compile_model(self.config.material)

    def compute(self, direction, should_stop=None):
        """The every-order model of one direction."""
        from vcavity.analytic.specular_orders import specular_orders
        from vcavity.sensor.directions import incident_vector

        c = self.config
        return specular_orders(c.material, incident_vector(direction.theta_i, direction.phi_i), self.sensor,
                               c.max_order, c.effective_max_bounces, tolerance=self.tolerance,
                               should_stop=should_stop)

    def reached(self) -> np.ndarray:
        """Per direction, whether its model met :attr:`tolerance` (False: the mesh hit its size
        cap first, and the table's error estimate says by how much it missed)."""
        return np.array([model.converged for model in self.models], dtype=bool)

    def ready_line(self, seconds: float) -> str:
        """What ``vcavity run`` says once the models are prepared."""
        return (f"every-order model of {len(self.config.incidence)} direction(s) in {seconds:.2f} s "
                "(deterministic: no path traced)")


__all__ = ["NAME", "ExactModels"]
