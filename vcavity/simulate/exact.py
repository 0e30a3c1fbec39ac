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

import time

import numpy as np

from vcavity.analytic.specular_orders import DEFAULT_TOLERANCE, specular_orders


class ExactModels:
    """The every-order model of each incident direction of ``config``.

    Parameters
    ----------
    config : vcavity.config.RunConfig
        A validated run with ``estimator = "exact"`` (specular facets).
    sensor : vcavity.sensor.grid.EqualAreaSensor
    incident : callable
        ``incident(theta_i, phi_i) -> unit vector`` toward the light.

    Attributes
    ----------
    models : list of SpecularOrders or None
        Per direction, None before :meth:`prepare`.
    time_s : float
        Seconds spent computing them.
    """

    def __init__(self, config, sensor, incident):
        self.config, self.sensor, self._incident = config, sensor, incident
        self.models: list | None = None
        self.time_s = 0.0

    @property
    def tolerance(self) -> float:
        """The model's tolerance: ``target_error`` when given, else the default."""
        return self.config.target_error if self.config.target_error is not None else DEFAULT_TOLERANCE

    def prepare(self, on_direction=None) -> float:
        """Compute every direction's model; ``on_direction(j)`` after each. Returns the seconds."""
        if self.models is not None:
            return 0.0
        t0 = time.perf_counter()
        c = self.config
        models = []
        for j, d in enumerate(c.incidence):
            models.append(specular_orders(c.material, self._incident(d.theta_i, d.phi_i), self.sensor, c.max_order,
                                          c.effective_max_bounces, tolerance=self.tolerance))
            if on_direction is not None:
                on_direction(j)
        self.models = models
        self.time_s = time.perf_counter() - t0
        return self.time_s

    def tabulated(self, orders):
        """``brdf``, ``brdf_stderr`` (n_i, n_k, n_c), ``albedo`` (n_i, n_k), the lost
        fractions (n_i, 3: absorbed, truncated, degenerate) and the relative error of f_inf.

        ``orders`` is the table's order axis (0 = f_inf, then 1..K; or 1..K). Without
        ``track_all_orders`` the orders beyond K are stopped after K bounces, as in the
        walk: they count as truncated, and f_inf is the sum of 1..K.
        """
        track = self.config.track_all_orders
        area = self.sensor.cell_projected_solid_angle
        n_i = len(self.models)
        brdf = np.zeros((n_i, len(orders), self.sensor.n_cells))
        stderr = np.zeros_like(brdf)
        lost = np.zeros((n_i, 3))
        error = np.full(n_i, np.nan)
        for j, model in enumerate(self.models):
            for position, k in enumerate(orders):
                values, errors = model.order(k, beyond=track)
                brdf[j, position], stderr[j, position] = values / area, errors / area
            beyond = 0.0 if track else float(model.integrals[model.max_order].sum())
            lost[j] = (model.absorbed, model.truncated + beyond, 0.0)
            if 0 in orders:
                inf = list(orders).index(0)
                exited = float(np.sum(brdf[j, inf] * area))
                error[j] = float(np.sum(stderr[j, inf] * area)) / exited if exited > 0.0 else np.inf
        albedo = np.einsum("ikc,c->ik", brdf, area)
        return brdf, stderr, albedo, lost, error


__all__ = ["ExactModels"]
