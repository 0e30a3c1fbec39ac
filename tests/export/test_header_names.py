"""File names holding control characters never break the text headers of exports.

A trial exported a table named ``new<newline>line.h5`` to CSV: the ``# source table``
comment line was split, its second half had no ``#``, and the file's own read recipe
(``numpy.loadtxt(FILE, delimiter=',', skiprows=N)``, N from the first line) failed. Every
export writing a text header (CSV ``#`` lines, the albedo LUT's C headers in both
layouts, the RGL file's description) must keep each comment one line: control
characters are written as escapes (``\\n``). Synthetic tables and sweeps (nothing
simulated). Deterministic: no false-positive rate.
"""

import numpy as np

from tests.export import test_albedo_cycles as cycles_case
from tests.export.synthetic_sweeps import synthetic_sweep
from tests.export.synthetic_table import synthetic
from tests.reference.tensor_file_reader import read_tensor_file
from vcavity.cli import main

ODD = "new\nline\r\x1b\u2028"  # newline, carriage return, escape, Unicode line separator
ESCAPED = "new\\nline\\r\\x1b\\u2028"


def test_csv_header_stays_one_line_per_comment_and_the_read_recipe_works(tmp_path, capsys):
    table = synthetic(tmp_path / f"{ODD}.h5", theta_deg=(0, 40), resolution=9)
    out = tmp_path / "slice.csv"
    assert main(["export", str(table.path), str(out), "--format", "csv", "--theta-i", "40"]) == 0, \
        capsys.readouterr().err
    lines = out.read_text(encoding="utf-8").split("\n")  # only "\n" ends a line here
    skip = int(lines[0].split("skiprows=")[1].rstrip(")"))
    assert all(line.startswith("# ") for line in lines[:skip - 1]), lines[:skip]
    assert lines[skip - 1].startswith("theta_o_deg,")
    assert any(line.startswith("# source table: ") and f"{ESCAPED}.h5 (written by" in line for line in lines[:skip])
    data = np.loadtxt(out, delimiter=",", skiprows=skip)
    assert data.shape == (len([line for line in lines[skip:] if line]), 5)


def _comment_block(text):
    """The lines of a C header's leading ``/* ... */`` comment."""
    lines = text.split("\n")
    end = lines.index(" */")
    assert lines[0].startswith("/*"), lines[0]
    return lines[1:end]


def test_albedo_lut_c_headers_keep_every_comment_line(tmp_path, capsys):
    midpoints = list(np.degrees(np.arccos([0.75, 0.25])))  # mu at the midpoints of 2 bins, as the LUT needs
    vcavity_layout = synthetic_sweep(tmp_path / f"{ODD}a.h5", [("alpha", [0.2, 0.5]), ("theta_i_deg", midpoints)],
                                     lambda coords, order: 0.5 / (order + 1))
    cycles_layout = synthetic_sweep(tmp_path / f"{ODD}c.h5", [("alpha", list(cycles_case.ALPHA)),
                                                               ("theta_i_deg", list(cycles_case.THETA))],
                                    cycles_case._albedo, orders=(0, 1, 2, 3), paths=cycles_case._paths)
    for source, flags, name in ((vcavity_layout, [], "a"), (cycles_layout, ["--layout", "cycles"], "c")):
        out = tmp_path / f"lut_{name}.h"
        assert main(["export", str(source), str(out), "--format", "albedo-lut", *flags]) == 0, capsys.readouterr().err
        block = _comment_block(out.read_text(encoding="utf-8"))
        assert all(line.startswith(" *") for line in block), block
        assert f" * sweep_file: {ESCAPED}{name}.h5" in block, block


def test_rgl_description_is_one_line(tmp_path, capsys):
    table = synthetic(tmp_path / f"{ODD}.h5", theta_deg=(0, 40, 80), resolution=9)
    out = tmp_path / "t.bsdf"
    assert main(["export", str(table.path), str(out), "--format", "rgl"]) == 0, capsys.readouterr().err
    description = read_tensor_file(out)["description"]
    description = description.tobytes().decode() if hasattr(description, "tobytes") else str(description)
    assert f"table {ESCAPED}.h5:" in description and not any(c in description for c in "\n\r\x1b\u2028")
