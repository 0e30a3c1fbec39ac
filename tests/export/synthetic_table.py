"""Tables of closed-form BRDFs for the export tests, written without simulating.

Each order holds ``f`` at the cell centres, stored as counts at 1e15 paths through
``write_table`` (as tests/brdf/test_table_brdf.py does), so ``table.brdf`` is ``f(centre)`` to ~1e-15
relative and nothing is compiled. Order ``k >= 1`` holds ``f / (k + 1)`` (integer division
of the counts), so orders are told apart.
"""

from __future__ import annotations

import numpy as np

from vcavity.io.table import open_table, write_table
from tests.io.tables import analog_table
from vcavity.sensor.grid import EqualAreaSensor

PATHS = 10**15
ISOTROPIC = {"distribution": "beckmann", "facet": "interfaced_lambertian", "alpha_x": 0.3,
             "alpha_y": 0.3, "kd": 0.9, "eta": 1.5}
ANISOTROPIC = dict(ISOTROPIC, alpha_x=0.2, alpha_y=0.4)


def direction(theta, phi):
    """Unit vectors of polar angle ``theta`` and azimuth ``phi`` (rad), broadcast."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)


def mirror(wi):
    """The mirror direction of ``wi`` about the normal ``+z``."""
    return wi * np.array([-1.0, -1.0, 1.0])


def lobe(wi, wo):
    """Isotropic, mirror-symmetric about the plane of incidence, not reciprocal (the
    ``wo_z`` term): a floor, a ramp in ``wo_z`` and a lobe about the mirror direction."""
    return 0.05 + 0.05 * wo[..., 2] + 0.5 * np.exp(-(1.0 - np.sum(wo * mirror(wi), -1)) / 0.1)


def synthetic(path, f=lobe, theta_deg=(0, 10, 20, 30, 40, 50, 60, 70, 80, 85), phi_deg=0.0,
              resolution=15, material=ISOTROPIC, orders=(0, 1)):
    """Write and open a table holding ``f`` (module docstring).

    Parameters
    ----------
    path : path
    f : callable ``f(wi (3,), wo (n, 3)) -> (n,)``
    theta_deg, phi_deg : incident directions, degrees (``phi_deg`` scalar or one per theta)
    resolution : int
        Sensor resolution N.
    material : dict
    orders : tuple of int
        The order axis (0 = f_inf).
    """
    sensor = EqualAreaSensor(resolution)
    theta_deg = np.asarray(theta_deg, dtype=np.float64)
    phi_deg = np.broadcast_to(np.asarray(phi_deg, dtype=np.float64), theta_deg.shape)
    theta, phi = np.radians(theta_deg), np.radians(phi_deg)
    counts = np.zeros((theta.size, len(orders), sensor.n_cells), dtype=np.int64)
    for j, wi in enumerate(direction(theta, phi)):
        full = np.round(PATHS * f(wi, sensor.cell_center) * sensor.cell_projected_solid_angle)
        for slot, k in enumerate(orders):
            counts[j, slot] = full.astype(np.int64) // (k + 1 if k else 1)
    exits = counts[:, 0].sum(axis=1) if orders[0] == 0 else counts.sum(axis=(1, 2))
    assert np.all(exits <= PATHS)
    zeros = np.zeros(theta.size, dtype=np.int64)
    write_table(path, analog_table(theta_i=theta, phi_i=phi, order=list(orders), counts=counts,
                paths=np.full(theta.size, PATHS), absorbed_paths=PATHS - exits,
                truncated_paths=zeros, degenerate_paths=zeros, max_bounces_seen=zeros + 1,
                sensor=sensor, material=material, config={}, seed=0, block_size=1,
                max_bounces=1, theta_i_deg=theta_deg, phi_i_deg=phi_deg))
    return open_table(path)
