"""RGL exports of anisotropic tables at the edges of the azimuth rule (docs/exports.md, "RGL").

A trial exported tables with ``phi_i_deg = [0, 90]`` and ``[0, 180]`` (one theta_i, no
normal-incidence row), which the docs accept, and got a traceback from the table API
(``DirectionNotTabulated``): the file's ``theta_i = 0`` node reached ``Table.eval`` as
``(-0.0, 0.0, 1.0)``, read as azimuth 180 deg, and ``[0, 180]`` leaves 45 deg unserved
(the table API interpolates azimuths only across gaps of at most 90 deg). Here: the
first exports, the second is refused in one line before anything is written, and no
``DirectionNotTabulated`` escapes an export as a traceback. Tables are synthetic closed
forms (tests/export/synthetic_table.py); the export compiles only the distribution's D.
Deterministic: no false-positive rate.
"""

import numpy as np
import pytest

from tests.export.synthetic_table import ANISOTROPIC, synthetic
from tests.reference.tensor_file_reader import read_tensor_file
from vcavity.cli import main


def _snapshot(folder):
    return sorted((p.name, p.read_bytes()) for p in folder.iterdir())


def test_normal_incidence_is_the_same_direction_whatever_the_sign_of_its_zeros(tmp_path):
    """Table API: (-0.0, 0.0, 1.0) and (0.0, -0.0, 1.0) are +z, served as +z is (a table
    without a normal-incidence row, azimuths 0 and 90 deg only)."""
    table = synthetic(tmp_path / "an.h5", theta_deg=(30, 30), phi_deg=(0, 90), material=ANISOTROPIC)
    wo = np.array([[0.3, 0.2, 0.9], [-0.5, 0.1, 0.7], [0.0, -0.6, 0.8]])
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    plus_z = table.eval(np.tile([0.0, 0.0, 1.0], (3, 1)), wo)
    assert np.all(plus_z > 0)
    for signed in ([-0.0, 0.0, 1.0], [0.0, -0.0, 1.0], [-0.0, -0.0, 1.0]):
        assert np.array_equal(table.eval(np.tile(signed, (3, 1)), wo), plus_z), signed


@pytest.mark.parametrize("fmt", ["rgl", "rgl-spectral"])
def test_a_table_spanning_0_to_90_deg_exports(tmp_path, capsys, fmt):
    """phi_i_deg = [0, 90] at one theta_i: the file holds azimuths -180 .. -90 deg in
    steps of 22.5 and its slices are finite and lit."""
    table = synthetic(tmp_path / "an.h5", theta_deg=(30, 30), phi_deg=(0, 90), material=ANISOTROPIC)
    out = tmp_path / "an.bsdf"
    assert main(["export", str(table.path), str(out), "--format", fmt]) == 0, capsys.readouterr().err
    fields = read_tensor_file(out)
    assert np.allclose(fields["phi_i"], np.radians(np.arange(-180, -89.99, 22.5)), atol=1e-6)
    colour = fields["rgb" if fmt == "rgl" else "spectra"]
    assert np.all(np.isfinite(colour)) and np.all(colour.max(axis=(-1, -2)) > 0)


def test_a_gap_wider_than_the_table_api_interpolates_is_refused_in_one_line(tmp_path, capsys):
    """phi_i_deg = [0, 180]: Table.eval serves no azimuth strictly between (gap 180 > 90
    deg), so the file cannot be filled: exit 2, one line naming the azimuths and the rule,
    the folder unchanged."""
    table = synthetic(tmp_path / "an.h5", theta_deg=(40, 40), phi_deg=(0, 180), material=ANISOTROPIC)
    (tmp_path / "an.bsdf").write_bytes(b"precious")
    before = _snapshot(tmp_path)
    for fmt in ("rgl", "rgl-spectral"):
        capsys.readouterr()
        assert main(["export", str(table.path), str(tmp_path / "an.bsdf"), "--format", fmt, "--overwrite"]) == 2
        captured = capsys.readouterr()
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and captured.out == "", captured.err
        assert f"--format {fmt} needs" in lines[0] and "at most 90 deg apart" in lines[0], lines[0]
        assert "phi_i_deg 0, 180, a gap of 180 deg" in lines[0], lines[0]
        assert _snapshot(tmp_path) == before


def test_no_direction_error_escapes_an_export(tmp_path, capsys, monkeypatch):
    """Should a format's own check let through a table it cannot fill, the table API's
    DirectionNotTabulated is still one line and exit 2, nothing written."""
    from vcavity.export import rgl

    table = synthetic(tmp_path / "an.h5", theta_deg=(40, 40), phi_deg=(0, 180), material=ANISOTROPIC)
    steps = np.arange(rgl.AZIMUTH_SUBDIVISIONS) / rgl.AZIMUTH_SUBDIVISIONS
    monkeypatch.setattr(rgl, "file_azimuths", lambda t, name: np.radians(np.append(180 * steps, 180.0)) - np.pi)
    before = _snapshot(tmp_path)
    assert main(["export", str(table.path), str(tmp_path / "an.bsdf"), "--format", "rgl"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "is not served by anisotropic table" in lines[0], lines
    assert _snapshot(tmp_path) == before
