"""``vcavity plot`` and ``vcavity compare --plots`` on a disk that is full (a trial found
57-line tracebacks, exit 1; for compare exit 1 reads as "the chi-square test failed").

Each case: exit status 2 (distinct from compare's FAIL, 1), one line on stderr saying the
write failed and that nothing was written, nothing on stdout, and the disk exactly as
before (files byte for byte, no temporary file, no folder made). The full disk is a real
tmpfs (root only, ``small_disk`` of tests/cli/test_faults.py); a failure between two of
compare's PNGs is made by failing the second write. Tables are synthetic closed forms
(tests/export/synthetic_table.py); compare compiles its f1 model. Deterministic: no
false-positive rate.
"""

import errno

import pytest

from tests.cli import test_faults
from tests.cli.test_faults import _leave_free, snapshot
from tests.export.synthetic_sweeps import synthetic_sweep
from tests.export.synthetic_table import synthetic
from vcavity.cli import main
from vcavity.io import atomic

small_disk = test_faults.small_disk  # the fixture: a 256 kB tmpfs
NO_SPACE = "(No space left on device); nothing was written"


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sources")
    table = synthetic(folder / "t.h5", theta_deg=(0, 40), resolution=9).path
    sweep = synthetic_sweep(folder / "s.h5", [("alpha", [0.2, 0.5]), ("theta_i_deg", [0.0, 60.0])],
                            lambda coords, order: 0.5 / (order + 1))
    return {"table": table, "sweep": sweep}


def _refused(capsys, argv, expected_start):
    capsys.readouterr()
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1, captured.err
    assert lines[0].startswith(f"vcavity: error: {expected_start}") and lines[0].endswith(NO_SPACE), lines[0]


PLOTS = [("p.png", ["--kind", "slice", "--no-models"]), ("p.svg", ["--kind", "map"]),
         ("p.pdf", ["--kind", "albedo"]), ("old.png", ["--kind", "albedo", "--overwrite"])]


@pytest.mark.parametrize("name, flags", PLOTS, ids=[p[0] + " " + p[1][1] for p in PLOTS])
def test_plot_on_a_full_disk_is_one_line(small_disk, sources, capsys, name, flags):
    (small_disk / "old.png").write_bytes(b"an older image\n" * 64)
    _leave_free(small_disk, 4 * 1024)
    before = snapshot(small_disk)
    out = str(small_disk / name)
    _refused(capsys, ["plot", str(sources["table"]), "-o", out, *flags], f"-o = {out!r}: writing failed ")
    assert snapshot(small_disk) == before


def test_plot_of_a_sweep_file_on_a_full_disk_is_one_line(small_disk, sources, capsys):
    _leave_free(small_disk, 4 * 1024)
    before = snapshot(small_disk)
    out = str(small_disk / "s.png")
    _refused(capsys, ["plot", str(sources["sweep"]), "-o", out], f"-o = {out!r}: writing failed ")
    assert snapshot(small_disk) == before


def test_compare_plots_on_a_full_disk_is_exit_2_not_a_failed_test(small_disk, sources, capsys):
    """A new folder (not left behind) and an existing one holding an older PNG of the same
    name (untouched)."""
    (small_disk / "old").mkdir()
    (small_disk / "old" / "compare_vcavity_theta0_phi0.png").write_bytes(b"an older plot\n" * 64)
    _leave_free(small_disk, 4 * 1024)
    before = snapshot(small_disk)
    for folder in (small_disk / "new", small_disk / "old"):
        _refused(capsys, ["compare", str(sources["table"]), "--plots", str(folder)],
                 f"--plots = {str(folder)!r}: writing the plots failed ")
        assert snapshot(small_disk) == before and not (small_disk / "new").exists()


def test_compare_plots_failing_after_the_first_png_leave_nothing(tmp_path, sources, capsys, monkeypatch):
    calls = []
    real = atomic.write_bytes

    def second_fails(temporary, data):
        calls.append(temporary)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(temporary, data)

    monkeypatch.setattr(atomic, "write_bytes", second_fails)
    _refused(capsys, ["compare", str(sources["table"]), "--plots", str(tmp_path / "a")],
             "--plots = ")
    assert len(calls) == 2 and list(tmp_path.iterdir()) == []


def test_compare_refuses_plots_in_a_missing_folder_as_plot_does(tmp_path, sources, capsys):
    target = tmp_path / "missing" / "x"
    capsys.readouterr()
    assert main(["compare", str(sources["table"]), "--plots", str(target)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [f"vcavity: error: --plots = {str(target)!r}: folder {str(target.parent)!r} does not exist; "
                     "compare creates only 'x' itself"]
    assert list(tmp_path.iterdir()) == []
    # the folder itself is made when the one above it exists (README: --plots plots/); the
    # synthetic table is not the model's, so the test itself FAILs: 1
    assert main(["compare", str(sources["table"]), "--plots", str(tmp_path / "plots")]) == 1
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == ["compare_vcavity_theta0_phi0.png",
                                                                       "compare_vcavity_theta40_phi0.png"]
