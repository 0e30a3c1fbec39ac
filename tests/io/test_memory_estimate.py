"""The memory preflight counts the table's HDF5 image, held twice while it is written.

``write_hdf5`` builds the table in memory (h5py's ``core`` driver) and copies its image to
bytes before writing them out; the estimate of a run's peak (``run_memory_bytes``) must
cover both beside the writer's arrays. Checked against the size of a real table written
the same way (its file is its image): a shape whose peak is the write (many directions,
few orders), where an estimate without the image is too low. Deterministic.
"""

from tests.export.synthetic_table import synthetic
from vcavity.io.preflight import run_memory_bytes


def test_the_write_peak_covers_two_copies_of_the_image(tmp_path):
    theta = tuple(float(t) for t in range(0, 80, 2))  # 40 directions: the write is the peak
    table = synthetic(tmp_path / "t.h5", theta_deg=theta, resolution=21, orders=(0, 1))
    n_inc, n_orders, n_cells = len(theta), 2, 21 * 21
    image = (tmp_path / "t.h5").stat().st_size
    arrays = 11 * 8 * n_inc * n_orders * n_cells  # the writer's arrays (preflight's own count)
    assert table.brdf.shape == (n_inc, n_orders, n_cells)
    assert run_memory_bytes(n_inc, n_orders, 1, n_cells, threads=2) >= arrays + 2 * image
