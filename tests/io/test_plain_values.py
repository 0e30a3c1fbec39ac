"""No NumPy repr in a message (issue 38 item 2): with NumPy 2 ``repr(np.float64(0.5))`` is
``np.float64(0.5)``, which is no value a user wrote or can paste back. The one-line errors
of damaged tables quote the stored and expected values as plain numbers.

Files are synthetic (tests/export), damaged with h5py; ``vcavity info`` reads them in
process. Nothing here is statistical.
"""

import re

import h5py
import pytest

from tests.export.synthetic_table import synthetic
from vcavity.cli import main

NUMPY_REPR = re.compile(r"\bnp\.\w+\(|numpy\.\w+\(")


@pytest.mark.parametrize("dataset, index, value, words", [
    ("albedo", (0, 0), 0.3, "must equal the sum of brdf x cell_projected_solid_angle over the cells, "),
    ("cell_solid_angle", (3,), 0.3, "must equal the value of the 7 x 7 sensor, "),
])
def test_a_damaged_tables_error_quotes_plain_numbers(tmp_path, capsys, dataset, index, value, words):
    path = synthetic(tmp_path / "t.h5", theta_deg=(0, 30), resolution=7).path
    with h5py.File(path, "r+") as h5:
        h5[dataset][index] = value
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and words in err and not NUMPY_REPR.search(err), err
    expected = err.split(words, 1)[1].split(" ", 1)[0].rstrip(",")
    assert float(expected) > 0  # the value the check expected, written as a number

