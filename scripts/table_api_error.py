"""Interpolation error of the table API (vcavity.brdf.table_brdf) against the analytic f1.

For a material, writes an "exact" single-bounce table: every cell holds the cell average
of the V-cavity single-bounce model (vcavity.analytic.cells.cell_average, the quantity a
simulation estimates, physics.md sec. 6), stored through write_table as counts at
1e18 paths (quantisation 1e-18 of the albedo). Then compares ``t.eval(wi, wo, order=1)``
with ``SingleBounceModel(material).brdf(wi, wo)`` and prints (docs/table-api.md):

- ``L1``: energy-weighted relative L1 error ``∫|eval - f| cos dω_o / ∫ f cos dω_o``,
  averaged over incident directions;
- ``RMS``: ``sqrt(∫ (eval - f)^2 dω_o / ∫ f^2 dω_o)`` over the same directions;
- ``E``: max over tabulated ``theta_i`` of ``|∫ eval cos dω_o / albedo - 1|`` (how far
  the interpolant is from conserving the tabulated albedo), by Gauss-Legendre quadrature
  on the cells of a 2N sensor (each lies inside one bilinear patch).

Outgoing directions are drawn from a defensive mixture (half uniform on the hemisphere,
half from ``t.sample``) and weighted by 1/density, so both the lobe and the rest are
covered. Incident directions: ``tabulated`` = tabulated ``theta_i`` at random ``phi_i``
(cell interpolation and rotation only); ``between`` = ``theta_i`` uniform in [0, 80] deg
(adds interpolation in ``theta_i``).

Usage::

    python scripts/table_api_error.py --resolution 57 113 --theta-step 5 2.5
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from vcavity.analytic.cells import cell_integrals
from vcavity.analytic.quadrature import subcell_quadrature
from vcavity.analytic.single_bounce import SingleBounceModel
from vcavity.config import Material, validate
from vcavity.estimators import analog
from vcavity.estimators.tabulate import tabulate
from vcavity.io.table import open_table, write_table
from vcavity.sensor.grid import EqualAreaSensor

MATERIALS = {
    "smooth": dict(distribution="beckmann", alpha=0.6, facet="interfaced_lambertian", kd=0.9, eta=1.5),
    "sharp": dict(distribution="beckmann", alpha=0.05, facet="interfaced_lambertian", kd=0.0, eta=1.5),
}
PATHS = 10**18


def direction(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def exact_table(path, material, resolution, theta_deg):
    """Write the single-bounce cell averages of ``material`` as an order-1 table."""
    sensor = EqualAreaSensor(resolution)
    model = SingleBounceModel(material)
    theta = np.radians(theta_deg)
    counts = np.zeros((theta.size, 1, sensor.n_cells), dtype=np.int64)
    for j, t in enumerate(theta):
        counts[j, 0] = np.round(PATHS * cell_integrals(model, direction(t, 0.0), sensor))
    paths = np.full(theta.size, PATHS)
    # the analog estimator's table of these counts: order slot 1 holds them, the rest is absorbed
    config = validate({"material": material.to_dict(), "incidence": {"theta_i_deg": list(theta_deg), "paths": PATHS},
                       "simulation": {"max_order": 1, "max_bounces": 1, "track_all_orders": False,
                                      "sensor_resolution": resolution, "fold_symmetry": False}})
    tally = np.zeros((theta.size, 1, 2, sensor.n_cells), dtype=np.int64)
    tally[:, 0, 1] = counts[:, 0]
    stats = np.zeros((theta.size, len(analog.STATS)), dtype=np.int64)
    stats[:, analog.STATS.index("absorbed")] = paths - counts.sum(axis=(1, 2))
    write_table(path, tabulate(config, sensor, analog, tally, stats, paths, block_size=1))
    return open_table(path), model


def errors(table, model, incident_theta, rng, n_out=4096):
    """Energy-weighted relative L1 and relative RMS over the incident directions given."""
    sums = np.zeros(4)  # Σ|e-f| cos/q, Σ f cos/q, Σ (e-f)^2/q, Σ f^2/q
    for theta in incident_theta:
        wi = direction(theta, rng.uniform(-np.pi, np.pi))
        uniform = rng.normal(size=(n_out // 2, 3))
        uniform[:, 2] = np.abs(uniform[:, 2])
        uniform /= np.linalg.norm(uniform, axis=1, keepdims=True)
        sampled, _, _ = table.sample(wi, rng.random(n_out // 2), rng.random(n_out // 2), order=1)
        wo = np.concatenate([uniform, sampled])
        density = 0.5 / (2.0 * np.pi) + 0.5 * table.pdf(wi, wo, order=1)
        e, f = table.eval(wi, wo, order=1), model.brdf(wi, wo)
        cos = wo[:, 2]
        sums += [np.sum(np.abs(e - f) * cos / density), np.sum(f * cos / density),
                 np.sum((e - f) ** 2 / density), np.sum(f * f / density)]
    return sums[0] / sums[1], np.sqrt(sums[2] / sums[3])


def energy_error(table):
    """max_j |∫ eval cos dω / albedo_j - 1| at the tabulated theta_i (phi_i = 0)."""
    fine = EqualAreaSensor(2 * table.sensor.resolution)  # cell edges on the patch edges
    dirs, weights = subcell_quadrature(fine, 4)
    dirs, weights = dirs.reshape(-1, 3), weights.ravel()
    worst = 0.0
    for j, theta in enumerate(table.theta_i):
        e = table.eval(direction(theta, 0.0), dirs, order=1)
        worst = max(worst, abs(np.sum(e * dirs[:, 2] * weights) / table.albedo[j, 0] - 1.0))
    return worst


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, nargs="+", default=[57])
    parser.add_argument("--theta-step", type=float, nargs="+", default=[5.0])
    parser.add_argument("--materials", nargs="+", default=list(MATERIALS), choices=list(MATERIALS))
    parser.add_argument("--incident", type=int, default=48, help="incident directions per figure")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    print("| material | N | theta_i step | L1 tabulated | RMS tabulated | L1 between | "
          "RMS between | E | build s |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for name in args.materials:
            material = Material.from_dict(MATERIALS[name])
            for resolution in args.resolution:
                for step in args.theta_step:
                    grid = np.arange(0.0, 85.0 + 1e-9, step)
                    start = time.perf_counter()
                    table, model = exact_table(os.path.join(scratch, "t.h5"), material,
                                               resolution, grid)
                    built = time.perf_counter() - start
                    rng = np.random.default_rng(args.seed)
                    on_grid = rng.choice(table.theta_i[table.theta_i <= np.radians(80.0)],
                                         args.incident)
                    between = rng.uniform(0.0, np.radians(80.0), args.incident)
                    l1_t, rms_t = errors(table, model, on_grid, rng)
                    l1_b, rms_b = errors(table, model, between, rng)
                    print(f"| {name} | {resolution} | {step:g} deg | {l1_t:.2e} | {rms_t:.2e} | "
                          f"{l1_b:.2e} | {rms_b:.2e} | {energy_error(table):.1e} | {built:.0f} |",
                          flush=True)


if __name__ == "__main__":
    main()
