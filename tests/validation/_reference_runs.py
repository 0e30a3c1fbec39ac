"""Shared plumbing of the tests that judge the simulator with tests/reference (not a test file).

Makes ``tests.reference`` importable (the repository root is appended to ``sys.path``;
pytest runs with ``--import-mode=importlib``, which does not add it), runs small
simulations through the public entry points (``vcavity.config.validate`` and
``vcavity.simulate.pipeline.simulate``), and turns counts plus reference probabilities into
fail-safe verdicts (``vcavity.analytic.statistics``: Pearson chi-square with pooling
and the albedo z-test, at a Sidak level).
"""

from __future__ import annotations

import math
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

from vcavity.analytic.statistics import albedo_z_test, pearson_chi_square, sidak_threshold  # noqa: E402
from vcavity.config import validate  # noqa: E402
from vcavity.simulate.pipeline import simulate  # noqa: E402

from tests.reference import materials as ref_materials  # noqa: E402


def run(material: dict, theta_deg, phi_deg, paths: int, resolution: int, seed: int, max_order: int = 1,
        track_all_orders: bool = True, max_bounces: int | None = None):
    """Simulate one or more incident directions; returns the table (a TableValue)."""
    thetas = list(theta_deg) if isinstance(theta_deg, (list, tuple)) else [theta_deg]
    phis = list(phi_deg) if isinstance(phi_deg, (list, tuple)) else [phi_deg] * len(thetas)
    sim = {"seed": seed, "max_order": max_order, "track_all_orders": track_all_orders,
           "sensor_resolution": resolution}
    if max_bounces is not None:
        sim["max_bounces"] = max_bounces
    cfg = validate({"material": dict(material),
                    "incidence": {"theta_i_deg": [float(t) for t in thetas],
                                  "phi_i_deg": [float(p) for p in phis], "paths": paths},
                    "simulation": sim})
    return simulate(cfg)


def sensor_of(result):
    """The sensor of a simulated table."""
    from vcavity.sensor.grid import EqualAreaSensor

    return EqualAreaSensor(int(result.attrs["sensor_resolution"]))


def order_counts(result, k: int, direction: int = 0) -> np.ndarray:
    """Per-cell counts of order ``k`` (0 = all orders) for one incident direction."""
    slot = int(np.flatnonzero(result["order"] == k)[0])
    return result["counts"][direction, slot]


def incident(theta_deg: float, phi_deg: float) -> np.ndarray:
    return ref_materials.direction(math.radians(theta_deg), math.radians(phi_deg))


def verdicts(observed, probabilities, paths: int):
    """``(chi-square result, albedo z-test result)`` of cell counts against probabilities."""
    probabilities = np.asarray(probabilities, dtype=np.float64)
    chi = pearson_chi_square(observed, paths * probabilities, paths)
    z = albedo_z_test(int(np.sum(observed)), float(probabilities.sum()), paths)
    return chi, z


def assert_pass(chi, z, level: float, label: str):
    """Both verdicts at ``level``; a chi-square must be testable."""
    assert chi.testable, f"{label}: chi-square not testable ({chi.n_categories} category)"
    msg = (f"{label}: chi2 {chi.verdict(level)} (stat {chi.statistic:.1f} on {chi.dof} dof, "
           f"worst cell z {chi.max_abs_z:.1f} at {chi.max_z_cell}); albedo {z.verdict(level)} "
           f"(observed {z.observed:.0f}, expected {z.expected:.1f}, z {z.z:.2f})")
    assert chi.passed(level) and z.passed(level), msg


__all__ = ["run", "order_counts", "incident", "verdicts", "assert_pass", "sidak_threshold", "lru_cache",
           "albedo_z_test", "pearson_chi_square"]
