"""Tables of format v2 are still read, as analog, unfolded tables without a target error.

tests/io/data/table_v2.h5 was written by the format-v2 writer of vcavity (commit 52448b9)
with tests/io/data/make_table_v2.py; the numbers checked here are that script's inputs.
"""

from pathlib import Path

import h5py
import numpy as np
import pytest

from vcavity.io.table import open_table

V2_TABLE = Path(__file__).parent / "data" / "table_v2.h5"
PATHS = [4000, 6000]


@pytest.fixture(scope="module")
def table():
    return open_table(V2_TABLE)


def test_fixture_is_a_v2_file():
    with h5py.File(V2_TABLE, "r") as h5:
        assert h5.attrs["format_version"] == 2
        assert "theta_i_deg" in h5 and "order_source" not in h5 and "estimator" not in h5.attrs


def test_v2_table_reads_as_analog_and_unfolded(table):
    assert table.format_version == 2 and table.estimator == "analog"
    np.testing.assert_array_equal(table.order_source, [0, 0, 0])
    np.testing.assert_array_equal(table.folded, [0, 0])
    np.testing.assert_array_equal(table.unbinned_paths, [0, 0])
    np.testing.assert_array_equal(table.target_reached, [-1, -1])
    assert np.all(np.isnan(table.relative_error))
    assert not table.is_analytic(1) and not table.is_analytic(0)
    np.testing.assert_array_equal(table.paths, PATHS)
    # the stored analog values are what they were: counts / (paths * projected solid angle)
    expected = table.counts / (table.paths[:, None, None] * table.cell_projected_solid_angle)
    np.testing.assert_allclose(table.brdf, expected, rtol=1e-15, atol=0)
