"""Regenerate table_v1.h5, the format-v1 fixture of tests/io/test_table_v1.py.

It must be written by the format-v1 writer, i.e. vcavity at commit aae24c0 (the last
commit before format v2), not by the current code:

    git worktree add /tmp/vcavity-v1 aae24c0
    cd tests/io/data && PYTHONPATH=/tmp/vcavity-v1 python make_table_v1.py

Sensor resolution 5, two incident directions with different phi_i, orders 0..2, a seed
above 2**63 (stored as uint64), and bookkeeping that closes: for each direction
exits (order 0) + absorbed + truncated + degenerate = paths.
"""

import numpy as np

import vcavity.io.table as table_module
from vcavity.sensor.grid import EqualAreaSensor

assert table_module.FORMAT_VERSION == 1, f"not the v1 writer: {table_module.__file__}"

SEED = 2**63 + 12345
THETA_I_DEG, PHI_I_DEG = [30.0, 60.0], [0.0, 45.0]
PATHS = [4000, 6000]
#: expected path fractions f1, f2, order > 2, absorbed, truncated, degenerate
SHARES = [0.5, 0.2, 0.1, 0.15, 0.04, 0.01]

sensor = EqualAreaSensor(5)
rng = np.random.default_rng(20250101)
counts = np.zeros((2, 3, sensor.n_cells), dtype=np.int64)
lost = np.zeros((3, 2), dtype=np.int64)
for i, paths in enumerate(PATHS):
    split = rng.multinomial(paths, SHARES)
    f1, f2, beyond = (rng.multinomial(n, np.full(sensor.n_cells, 1 / sensor.n_cells))
                      for n in split[:3])
    counts[i, 1], counts[i, 2], counts[i, 0] = f1, f2, f1 + f2 + beyond
    lost[:, i] = split[3:]
material = {"distribution": "beckmann", "facet": "interfaced_lambertian", "alpha_x": 0.5,
            "alpha_y": 0.5, "kd": 0.5, "eta": 1.5}
config = {"material": material,
          "incidence": {"theta_i_deg": THETA_I_DEG, "phi_i_deg": PHI_I_DEG, "paths": PATHS},
          "simulation": {"seed": SEED, "max_order": 2, "max_bounces": 100,
                         "track_all_orders": True, "sensor_resolution": 5},
          "output": {"path": None}, "source": "tests/io/data/make_table_v1.py"}
table_module.write_table(
    "table_v1.h5", theta_i=np.radians(THETA_I_DEG), phi_i=np.radians(PHI_I_DEG),
    order=[0, 1, 2], counts=counts, paths=PATHS, absorbed_paths=lost[0],
    truncated_paths=lost[1], degenerate_paths=lost[2], max_bounces_seen=[100, 100],
    sensor=sensor, material=material, config=config, seed=SEED, block_size=4096,
    max_bounces=100, compute_time_s=0.5, compile_time_s=0.25)
print("wrote table_v1.h5 with", table_module.__file__)
