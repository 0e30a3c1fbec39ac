"""Tables of format v1 are still read (docs/hdf5-format.md, *Versioning*).

tests/io/data/table_v1.h5 was written by the format-v1 writer of vcavity (commit aae24c0)
with tests/io/data/make_table_v1.py; the numbers checked here are that script's inputs.
"""

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from vcavity.io.table import TableFormatError, open_table
from vcavity.sensor.grid import EqualAreaSensor

V1_TABLE = Path(__file__).parent / "data" / "table_v1.h5"
SEED = 2**63 + 12345
THETA_I_DEG, PHI_I_DEG = [30.0, 60.0], [0.0, 45.0]
PATHS = [4000, 6000]


@pytest.fixture(scope="module")
def table():
    return open_table(V1_TABLE)


def test_fixture_is_a_v1_file():
    with h5py.File(V1_TABLE, "r") as h5:
        assert h5.attrs["format_version"] == 1
        assert "theta_i_deg" not in h5 and "incidence" not in h5
        assert list(h5["brdf"].dims[0].keys()) == ["theta_i", "phi_i"]  # the v1 layout


def test_v1_table_is_read(table):
    assert table.format_version == 1
    assert table.seed == SEED and table.config["simulation"]["seed"] == SEED
    np.testing.assert_allclose(table.theta_i, np.radians(THETA_I_DEG), rtol=0, atol=1e-15)
    np.testing.assert_allclose(table.phi_i, np.radians(PHI_I_DEG), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(table.order, [0, 1, 2])
    np.testing.assert_array_equal(table.paths, PATHS)
    np.testing.assert_array_equal(table.max_bounces_seen, [100, 100])
    assert table.material == {"distribution": "beckmann", "facet": "interfaced_lambertian",
                              "alpha_x": 0.5, "alpha_y": 0.5, "kd": 0.5, "eta": 1.5}
    assert table.attrs["block_size"] == 4096 and table.attrs["max_bounces"] == 100
    assert table.sensor == EqualAreaSensor(5) and table.counts.shape == (2, 3, 25)


def test_v1_bookkeeping_and_derived_values(table):
    counts, paths = table.counts, table.paths
    lost = sum(np.rint(getattr(table, name) * paths).astype(np.int64)
               for name in ("absorbed", "truncated", "degenerate"))
    np.testing.assert_array_equal(counts[:, 0].sum(axis=1) + lost, paths)
    assert np.all(counts[:, 1:].sum(axis=1) <= counts[:, 0])
    denominator = paths[:, None, None] * table.cell_projected_solid_angle
    np.testing.assert_allclose(table.brdf, counts / denominator, rtol=1e-14, atol=0)
    np.testing.assert_allclose(table.albedo, counts.sum(axis=2) / paths[:, None], rtol=1e-14)


def test_v1_gets_the_v2_fields(table):
    """Degrees from the radians, outgoing angles from the rebuilt sensor."""
    np.testing.assert_allclose(table.theta_i_deg, THETA_I_DEG, rtol=0, atol=1e-12)
    np.testing.assert_allclose(table.phi_i_deg, PHI_I_DEG, rtol=0, atol=1e-12)
    x, y, z = table.cell_center.T
    np.testing.assert_allclose(table.theta_o, np.arccos(z), rtol=0, atol=1e-7)
    np.testing.assert_allclose(np.cos(table.phi_o) * np.hypot(x, y), x, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.sin(table.phi_o) * np.hypot(x, y), y, rtol=0, atol=1e-15)
    for name in ("theta_i_deg", "phi_i_deg", "theta_o", "phi_o", "brdf"):
        assert not getattr(table, name).flags.writeable, name


def test_v1_table_lacking_a_v1_dataset_is_refused(tmp_path):
    broken = tmp_path / "v1.h5"
    shutil.copy(V1_TABLE, broken)
    with h5py.File(broken, "a") as h5:
        del h5["counts"]
    with pytest.raises(TableFormatError, match=r"^missing dataset 'counts' in .*v1\.h5$"):
        open_table(broken)
