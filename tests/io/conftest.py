"""Shared fixtures of the table tests: random but internally consistent integer counts.

Drawn with fixed seeds, so every check built on them is exact or rounding-level and
deterministic: nothing is statistical.
"""

import numpy as np
import pytest

from vcavity.io.table import write_table
from tests.io.tables import analog_table
from vcavity.sensor.grid import EqualAreaSensor

MATERIAL = {"distribution": "beckmann", "facet": "interfaced_lambertian", "kd": 0.9,
            "eta": 1.5, "alpha_x": 0.3, "alpha_y": 0.5, "exponent": None}
CONFIG = {"material": {"distribution": "beckmann", "alpha_x": 0.3, "alpha_y": 0.5},
          "simulation": {"seed": 7, "max_order": 3}, "incidence": {"theta_i": [0.0, 0.5, 1.2]}}


def _consistent_run(seed, sensor, n_incidence=3, max_order=3, with_all_orders=True):
    """Random integer counts obeying the bookkeeping of an analog walk (physics.md sec. 6).

    Every path is exactly one of: exits with order 1..K, exits with order > K,
    absorbed, truncated, degenerate. Order 0 (if kept) counts every exit.
    """
    rng = np.random.default_rng(seed)
    n_cells = sensor.n_cells
    paths = rng.integers(1_000, 50_000, size=n_incidence)
    n_orders = max_order + (1 if with_all_orders else 0)
    counts = np.zeros((n_incidence, n_orders, n_cells), dtype=np.int64)
    lost = np.zeros((3, n_incidence), dtype=np.int64)
    for i in range(n_incidence):
        shares = rng.dirichlet(np.ones(max_order + 4))
        split = rng.multinomial(paths[i], shares)  # orders 1..K, order > K, 3 losses
        per_order = [rng.multinomial(split[k], rng.dirichlet(np.ones(n_cells)))
                     for k in range(max_order + 1)]
        first = 1 if with_all_orders else 0
        for k in range(max_order):
            counts[i, first + k] = per_order[k]
        if with_all_orders:
            counts[i, 0] = np.sum(per_order, axis=0)
        lost[:, i] = split[max_order + 1:]
    if not with_all_orders:  # without f_inf, paths beyond K count as truncated
        lost[1] += paths - counts.sum(axis=(1, 2)) - lost.sum(axis=0)
    order = np.arange(0 if with_all_orders else 1, max_order + 1)
    return dict(
        theta_i=rng.uniform(0.0, 0.5 * np.pi, n_incidence),
        phi_i=rng.uniform(-np.pi, np.pi, n_incidence),
        order=order, counts=counts, paths=paths,
        absorbed_paths=lost[0], truncated_paths=lost[1], degenerate_paths=lost[2],
        max_bounces_seen=rng.integers(max_order, 500, n_incidence),
    )


def _write(path, run, sensor, **overrides):
    arguments = dict(run, sensor=sensor, material=MATERIAL, config=CONFIG, seed=7,
                     block_size=4096, max_bounces=1000, compute_time_s=1.5,
                     compile_time_s=0.25)
    arguments.update(overrides)
    write_table(path, analog_table(**arguments))


@pytest.fixture(scope="session")
def sensor():
    return EqualAreaSensor(5)


@pytest.fixture
def written(tmp_path, sensor):
    run = _consistent_run(2024, sensor)
    path = tmp_path / "table.h5"
    _write(path, run, sensor)
    return path, run


@pytest.fixture(scope="session")
def consistent_run():
    """``consistent_run(seed, sensor, n_incidence=3, max_order=3, with_all_orders=True)``."""
    return _consistent_run


@pytest.fixture(scope="session")
def write():
    """``write(path, run, sensor, **overrides)``: write_table with the standard metadata."""
    return _write


@pytest.fixture(scope="session")
def material():
    return dict(MATERIAL)


@pytest.fixture(scope="session")
def config():
    return dict(CONFIG)
