"""What a new user hit, each turned into a test: unsafe output paths, flags and
config fields out of range, memory and disk limits, Ctrl-C, a full disk, corrupt tables,
stale temporary files.

Every refusal: exit status 2, one line on stderr naming the field as the user wrote it
(``--seed``, ``output.path``, ``material.kd``), the value and what is accepted, nothing on
stdout, and the folder exactly as before (no table, no temporary file, the pre-existing
``old.h5`` byte for byte: sha256). Most cases run in-process through ``vcavity.cli.main``
(milliseconds: they fail before tracing); a few run as ``python -m vcavity.cli`` to check
what a shell sees (no traceback), and the whole table runs that way under ``-m slow``.
Runs that trace use the variant test_cli_bad_input.py compiles (beckmann + interfaced
Lambertian, kd 0.5, eta 1.5, 9 x 9 cells). No test here is statistical.
"""

import errno
import hashlib
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from vcavity import open_table
from vcavity.cli import main
from vcavity.io import atomic, checkpoint, sweep_points, writer
from vcavity.io.sweep_table import open_sweep

BASE = {"material.distribution": '"beckmann"', "material.alpha": "0.5", "material.kd": "0.5",
        "material.eta": "1.5", "incidence.theta_i_deg": "[0.0, 45.0]", "incidence.paths": "4096",
        "simulation.sensor_resolution": "9"}
RUN = ["run", "c.toml", "-o", "new.h5", "-q"]


def toml(changes=None, extra=""):
    """The base config with ``{"table.key": TOML text or None (drop)}`` changes."""
    values = {**BASE, **(changes or {})}
    tables = {}
    for dotted, text in values.items():
        if text is not None:
            table, key = dotted.split(".")
            tables.setdefault(table, []).append(f"{key} = {text}")
    return "".join(f"[{t}]\n" + "\n".join(lines) + "\n" for t, lines in tables.items()) + extra


def snapshot(folder):
    """Every entry under ``folder`` (links not followed): link target, sha256 of files, else the kind."""
    seen = {}
    for root, dirs, files in os.walk(folder):
        for path in (os.path.join(root, name) for name in dirs + files):
            mode = stat.S_IFMT(os.lstat(path).st_mode)
            seen[path] = (os.readlink(path) if mode == stat.S_IFLNK else
                          hashlib.sha256(Path(path).read_bytes()).hexdigest() if mode == stat.S_IFREG else mode)
    return seen


@pytest.fixture
def box(tmp_path, monkeypatch):
    """A working folder: a good config, a pre-existing table, a file, a folder, a FIFO, links."""
    (tmp_path / "c.toml").write_text(toml())
    (tmp_path / "old.h5").write_bytes(b"an older table\n" * 64)
    (tmp_path / "afile").write_text("a regular file\n")
    (tmp_path / "d").mkdir()
    os.mkfifo(tmp_path / "fifo")
    os.symlink("old.h5", tmp_path / "link.h5")
    os.symlink("nowhere.h5", tmp_path / "dangling.h5")
    os.link(tmp_path / "c.toml", tmp_path / "hard.h5")  # the config under another name
    (tmp_path / "a.h5").write_text(toml())  # a config named like a table
    (tmp_path / "self.toml").write_text(toml(extra='[output]\npath = "self.toml"\n'))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _main(argv):
    try:
        return main(argv)
    except SystemExit as exc:  # argparse
        return exc.code


# (id, argv, {file: content} written first, text the one error line must contain)
NEW_USER = [
    ("fifo", ["run", "c.toml", "-o", "fifo", "--overwrite", "-q"], {}, "--output = 'fifo': exists and is a FIFO"),
    ("symlink", ["run", "c.toml", "-o", "link.h5", "--overwrite", "-q"], {}, "--output = 'link.h5': is a symbolic link"),
    ("dangling-link", ["run", "c.toml", "-o", "dangling.h5", "-q"], {}, "--output = 'dangling.h5': is a symbolic link"),
    ("directory", ["run", "c.toml", "-o", "d", "--overwrite", "-q"], {}, "--output = 'd': is a directory"),
    ("o-is-config", ["run", "c.toml", "-o", "c.toml", "--overwrite", "-q"], {}, "--output = 'c.toml': is the run config"),
    ("hardlink-config", ["run", "c.toml", "-o", "hard.h5", "--overwrite", "-q"], {}, "--output = 'hard.h5': is the run config"),
    ("config-named-h5", ["run", "a.h5", "--overwrite", "-q"], {}, "output (default: the config's name with .h5) = 'a.h5': is the run config"),
    ("output-path-is-config", ["run", "self.toml", "--overwrite", "-q"], {}, "output.path = 'self.toml': is the run config"),
    ("exists-no-overwrite", ["run", "c.toml", "-o", "old.h5", "-q"], {}, "--output = 'old.h5': exists; pass --overwrite"),
    ("seed-overflow", RUN + ["--seed", "1180591620717411303424"], {}, "--seed = '1180591620717411303424': must be an integer >= 0"),
    ("seed-negative", RUN + ["--seed", "-1"], {}, "--seed = '-1': must be an integer >= 0"),
    ("paths-1e19", RUN + ["--paths", "1e19"], {}, "--paths = '1e19': must be an integer >= 1 and <= 4611686018427387904"),
    ("proc", ["run", "c.toml", "-o", "/proc/v.h5", "-q"], {}, "--output = '/proc/v.h5': cannot create a file in folder '/proc'"),
    ("sys", ["run", "c.toml", "-o", "/sys/v.h5", "-q"], {}, "--output = '/sys/v.h5': cannot create a file in folder '/sys'"),
    ("kd-omitted", RUN, {"c.toml": toml({"material.kd": None})}, "material.kd is missing: facet 'interfaced_lambertian' needs kd"),
    ("memory", RUN, {"c.toml": toml({"simulation.sensor_resolution": "2048", "simulation.max_order": "1000"})},
     "simulation.sensor_resolution = 2048 with max_order = 1000: the run needs about"),
    ("o-empty", ["run", "c.toml", "-o", "", "-q"], {}, "--output = '': must be a file path"),
    ("o-trailing-slash", ["run", "c.toml", "-o", "newdir/", "-q"], {}, "--output = 'newdir/': names a folder"),
    ("output-path-number", ["run", "c.toml", "-q"], {"c.toml": toml(extra="[output]\npath = 5\n")}, "output.path = 5: must be a non-empty string"),
    ("output-path-folder", ["run", "c.toml", "-q"], {"c.toml": toml(extra='[output]\npath = "out/"\n')}, "output.path = 'out/': names a folder"),
    ("output-path-missing-folder", ["run", "c.toml", "-q"], {"c.toml": toml(extra='[output]\npath = "no/t.h5"\n')}, "folder 'no' does not exist"),
    ("parent-is-file", ["run", "c.toml", "-o", "afile/x.h5", "-q"], {}, "--output = 'afile/x.h5': 'afile' is a file, not a folder"),
    ("output-parent-is-file", ["run", "c.toml", "-q"], {"c.toml": toml(extra='[output]\npath = "afile/t.h5"\n')},
     "output.path = 'afile/t.h5': 'afile' is a file, not a folder"),
    ("phi-1e300", RUN, {"c.toml": toml({"incidence.phi_i_deg": "1e300"})}, "incidence.phi_i_deg = 1e+300: must be in [-360, 360] degrees"),
    ("plots-is-file", ["compare", "old.h5", "--plots", "afile"], {}, "--plots = 'afile': is a file, not a folder"),
    ("plots-under-file", ["compare", "old.h5", "--plots", "afile/sub"], {}, "--plots = 'afile/sub': is under 'afile', a file"),
]

CONFIGS = [(f"config-{key}={text}", {key: text}, expected) for key, text, expected in [
    ("material.alpha", '"rough"', "material.alpha = 'rough'"),
    ("material.distribution", '"cauchy"', "material.distribution = 'cauchy'"),
    ("material.facet", '"velvet"', "material.facet = 'velvet'"),
    ("material.roughness", "0.2", "material.roughness = 0.2: unknown key"),
    ("incidence.theta_i_deg", "[]", "incidence.theta_i_deg = []: must not be empty"),
    ("incidence.theta_i_deg", '["30"]', "incidence.theta_i_deg = '30'"),
    ("incidence.theta_i_deg", "90", "incidence.theta_i_deg = 90: must be in [0, 90) degrees"),
    ("incidence.phi_i_deg", "[0, 0, 0]", "incidence.phi_i_deg = [0, 0, 0]: must be one value or a list of 2"),
    ("incidence.phi_i_deg", "nan", "incidence.phi_i_deg = nan: must be a finite number"),
    ("incidence.phi_i_deg", "-360.5", "incidence.phi_i_deg = -360.5: must be in [-360, 360] degrees"),
    ("incidence.paths", "0", "incidence.paths = 0: must be an integer >= 1"),
    ("incidence.paths", "1500.5", "incidence.paths = 1500.5: must be an integer >= 1"),
    ("incidence.paths", "1e300", "incidence.paths = 1e+300: must be an integer >= 1"),
    ("incidence.paths", "true", "incidence.paths = True: must be an integer"),
    ("incidence.psi", "3", "incidence.psi = 3: unknown key"),
    ("simulation.seed", "-1", "simulation.seed = -1: must be an integer >= 0"),
    ("simulation.seed", "18446744073709551616", "simulation.seed = 18446744073709551616: must be an integer >= 0"),
    ("simulation.seed", "1.5", "simulation.seed = 1.5: must be an integer"),
    ("simulation.max_order", "0", "simulation.max_order = 0: must be an integer >= 1"),
    ("simulation.max_order", "1001", "simulation.max_order = 1001: must be an integer >= 1 and <= 1000"),
    ("simulation.max_bounces", "2", "simulation.max_bounces = 2: must be >= simulation.max_order (3)"),
    ("simulation.track_all_orders", '"yes"', "simulation.track_all_orders = 'yes': must be true or false"),
    ("simulation.sensor_resolution", "0", "simulation.sensor_resolution = 0: must be an integer >= 1"),
    ("simulation.sensor_resolution", "2049", "simulation.sensor_resolution = 2049: must be an integer >= 1 and <= 2048"),
    ("simulation.sensor_resolution", '"57"', "simulation.sensor_resolution = '57': must be an integer"),
    ("simulation.estimator", '"fast"', "simulation.estimator = 'fast': accepted: 'analog'"),
    ("simulation.fold_symmetry", '"yes"', "simulation.fold_symmetry = 'yes': must be true or false"),
    ("simulation.target_error", "0", "simulation.target_error = 0: must be in (0, 1)"),
    ("simulation.max_paths", "1000", "simulation.max_paths = 1000: applies only with simulation.target_error"),
    ("simulation.threads", "2", "simulation.threads = 2: unknown key"),
    ("output.file", '"x.h5"', "output.file = 'x.h5': unknown key"),
    ("sweep.alpha", "[0.1]", "config.sweep = {'alpha': [0.1]}: unknown key"),
]] + [
    ("config-fold-at-10deg", {"simulation.fold_symmetry": "true", "incidence.phi_i_deg": "10"},
     "simulation.fold_symmetry = True: needs phi_i_deg a multiple of 45"),
    ("config-target-without-f_inf", {"simulation.target_error": "0.01", "simulation.track_all_orders": "false"},
     "simulation.target_error = 0.01: needs track_all_orders = true"),
]

FLAGS = [
    ("paths-0", RUN + ["--paths", "0"], {}, "--paths = '0': must be an integer >= 1"),
    ("paths-abc", RUN + ["--paths", "abc"], {}, "--paths = 'abc': must be an integer >= 1"),
    ("paths-1.5", RUN + ["--paths", "1.5"], {}, "--paths = '1.5': must be an integer >= 1"),
    ("paths-inf", RUN + ["--paths", "inf"], {}, "--paths = 'inf': must be an integer >= 1"),
    ("seed-1.5", RUN + ["--seed", "1.5"], {}, "--seed = '1.5': must be an integer >= 0"),
    ("seed-2**64", RUN + ["--seed", str(2**64)], {}, f"--seed = '{2**64}': must be an integer >= 0 and <= {2**64 - 1}"),
    ("threads-0", RUN + ["--threads", "0"], {}, "--threads = '0': must be an integer >= 1"),
    ("threads-above-cores", RUN + ["--threads", "4096"], {}, "--threads = 4096: must be between 1 and"),
    ("chunk-blocks-0", RUN + ["--chunk-blocks", "0"], {}, "--chunk-blocks = '0': must be an integer >= 1"),
    ("target-error-0", RUN + ["--target-error", "0"], {}, "--target-error = '0': expected a number in (0, 1)"),
    ("target-error-nan", RUN + ["--target-error", "nan"], {}, "--target-error = 'nan': expected a number in (0, 1)"),
    ("max-paths-alone", RUN + ["--max-paths", "100"], {}, "--max-paths = 100: applies only with --target-error"),
    ("max-paths-0", RUN + ["--target-error", "0.1", "--max-paths", "0"], {}, "--max-paths = '0': must be an integer >= 1"),
    ("estimator-bogus", RUN + ["--estimator", "bogus"], {}, "--estimator: invalid choice: 'bogus'"),
    ("estimator-nothing-to-simulate", RUN + ["--estimator", "exact-f1"],
     {"c.toml": toml({"simulation.max_order": "1", "simulation.track_all_orders": "false"})},
     "--estimator = 'exact-f1': with max_order = 1 and track_all_orders = false"),
    ("target-error-without-f_inf", RUN + ["--target-error", "0.1"], {"c.toml": toml({"simulation.track_all_orders": "false"})},
     "--target-error = 0.1: needs track_all_orders = true"),
    ("unknown-flag", RUN + ["--bogus"], {}, "unrecognized arguments: --bogus"),
    ("o-without-value", ["run", "c.toml", "-q", "-o"], {}, "--output: expected one argument"),
    ("no-command", [], {}, "the following arguments are required: COMMAND"),
    ("significance-2", ["compare", "old.h5", "--significance", "2"], {}, "--significance = '2': expected a number in (0, 1)"),
    ("nodes-0", ["compare", "old.h5", "--nodes", "0"], {}, "--nodes = '0': must be an integer >= 1 and <= 1024"),
    ("model-bogus", ["compare", "old.h5", "--model", "bogus"], {}, "--model: invalid choice: 'bogus'"),
    ("compare-missing", ["compare", "missing.h5"], {}, "table 'missing.h5': no such file"),
    ("info-not-a-table", ["info", "old.h5"], {}, "not a vcavity table: old.h5"),
    ("info-directory", ["info", "d"], {}, "not a vcavity table: d (not a regular file)"),
    ("info-fifo", ["info", "fifo"], {}, "not a vcavity table: fifo (not a regular file)"),  # did block
    ("config-missing", ["run", "missing.toml", "-q"], {}, "config file 'missing.toml': cannot read it"),
    ("config-is-directory", ["run", "d", "-q"], {}, "config file 'd': cannot read it"),
    ("config-bad-toml", RUN, {"c.toml": "[material\nalpha = 0.5\n"}, "config file 'c.toml': invalid TOML"),
    ("config-not-utf8", RUN, {"c.toml": b"\xff\xfe[material]\n"}, "config file 'c.toml': not UTF-8 text"),
    ("config-section-not-table", RUN, {"c.toml": "material = 5\n"}, "material = 5: must be a TOML table"),
]

CASES = NEW_USER + [(name, RUN, {"c.toml": toml(changes)}, text) for name, changes, text in CONFIGS] + FLAGS


def _prepare(folder, files):
    for name, content in files.items():
        target = folder / name
        target.write_bytes(content) if isinstance(content, bytes) else target.write_text(content)


def assert_refused(status, captured, expected, before, folder):
    lines = captured.err.splitlines()
    assert status == 2, captured.err
    assert captured.out == ""
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: "), captured.err
    assert expected in lines[0], lines[0]
    assert snapshot(folder) == before  # no table, no temporary file, old.h5 unchanged


SHELL_ONLY = ["info-fifo"]  # a regression would block reading the FIFO: a subprocess can time out


@pytest.mark.parametrize("name, argv, files, expected", [c for c in CASES if c[0] not in SHELL_ONLY],
                         ids=[c[0] for c in CASES if c[0] not in SHELL_ONLY])
def test_refused_before_tracing(box, capsys, name, argv, files, expected):
    if name in ("proc", "sys") and not os.path.isdir(f"/{name}"):
        pytest.skip(f"no /{name} here")
    _prepare(box, files)
    before = snapshot(box)
    assert_refused(_main(argv), capsys.readouterr(), expected, before, box)


# --- a full disk and Ctrl-C while the table is written (in-process: exact timing) ---------

def _run_over_old(argv_tail=()):
    return _main(["run", "c.toml", "-o", "old.h5", "--overwrite", "-q", *argv_tail])


def test_full_disk_during_the_write(box, capsys, monkeypatch):
    def full(h5, values):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(writer, "_write_datasets", full)
    before = snapshot(box)
    status = _run_over_old()
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if "error" in line]
    assert status == 2 and captured.out == "" and "Traceback" not in captured.err
    assert len(error) == 1 and "--output = 'old.h5': writing the table failed (No space left on device)" in error[0]
    after = snapshot(box)
    assert after.pop(str(box / "old.h5.checkpoint"))  # the finished run is kept, for --resume
    assert after == before


def _disk_full_at(monkeypatch, target, failing_call=1):
    """Make the byte write of ``target`` ("table" or "checkpoint") fail with ENOSPC on its
    ``failing_call``-th write, after writing half its bytes (a disk that filled mid-write)."""
    real, calls = atomic.write_bytes, []

    def write_bytes(temporary, data):
        is_checkpoint = ".checkpoint." in temporary.name
        if is_checkpoint == (target == "checkpoint"):
            calls.append(temporary)
            if len(calls) == failing_call:
                real(temporary, data[: len(data) // 2])
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(temporary, data)

    monkeypatch.setattr(atomic, "write_bytes", write_bytes)


def test_full_disk_writing_the_table_keeps_the_checkpoint(box, capsys, monkeypatch):
    before = snapshot(box)
    with monkeypatch.context() as patch:
        _disk_full_at(patch, "table")
        status = _run_over_old()
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if "error" in line]
    assert status == 2 and captured.out == "" and "Traceback" not in captured.err
    assert len(error) == 1 and ("--output = 'old.h5': writing the table failed (No space left on device); "
                                "nothing was written") in error[0] and "the checkpoint keeps the run" in error[0]
    after = snapshot(box)
    assert after.pop(str(box / "old.h5.checkpoint"))
    assert after == before  # old table unchanged, no temporary file
    assert _main(["run", "c.toml", "-o", "old.h5", "--overwrite", "--resume", "-q"]) == 0
    assert "resuming from old.h5.checkpoint (8,192 of 8,192 paths done)" in capsys.readouterr().err


def test_full_disk_writing_a_checkpoint_keeps_the_previous_one(box, capsys, monkeypatch):
    """Checkpoints every unit of work: the first is saved, the second meets a full disk.
    The error names the checkpoint, the first checkpoint stays and --resume continues it."""
    saved = {}
    real_save = checkpoint.save

    def save(path, *args):
        if Path(path).exists():  # the file the failing write must leave as it is
            saved.setdefault("first", Path(path).read_bytes())
        real_save(path, *args)

    before = snapshot(box)
    with monkeypatch.context() as patch:
        patch.setattr(checkpoint, "save", save)
        _disk_full_at(patch, "checkpoint", failing_call=2)
        status = _main(RUN + ["--checkpoint-every", "1e-9"])
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if "error" in line]
    assert status == 2 and captured.out == "" and "Traceback" not in captured.err
    assert len(error) == 1 and error[0] == (
        "vcavity: error: --output = 'new.h5': writing the checkpoint 'new.h5.checkpoint' failed (No space "
        "left on device); no table written, an existing file is unchanged; the previous checkpoint is unchanged")
    after = snapshot(box)
    assert (box / "new.h5.checkpoint").read_bytes() == saved["first"]
    after.pop(str(box / "new.h5.checkpoint"))
    assert after == before  # no table, no temporary file
    assert _main(RUN + ["--resume"]) == 0
    assert "resuming from new.h5.checkpoint (4,096 of 8,192 paths done)" in capsys.readouterr().err


def test_full_disk_in_a_sweep_is_one_line(box, capsys, monkeypatch):
    (box / "s.toml").write_text(toml({"incidence.theta_i_deg": None}, "[sweep]\nalpha = [0.3, 0.6]\n"
                                                                     "theta_i_deg = [0]\n"))
    # the first point writes the whole file; the disk fills in the in-place write of the
    # second, in its third piece of values (half of it written)
    real, calls = sweep_points.write_at, []

    def write_at(fd, data, offset):
        calls.append(offset)
        if len(calls) == 3:
            real(fd, data[: len(data) // 2], offset)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd, data, offset)

    monkeypatch.setattr(sweep_points, "write_at", write_at)
    before = snapshot(box)
    status = _main(["sweep", "s.toml", "-o", "s.h5", "-q"])
    captured = capsys.readouterr()
    error = [line for line in captured.err.splitlines() if "error" in line]
    assert status == 2 and captured.out == "" and "Traceback" not in captured.err
    assert error == ["vcavity: error: --output = 's.h5': writing the sweep failed (No space left on device); "
                     "the file holds the points finished before"]
    after = snapshot(box)
    assert after.pop(str(box / "s.h5"))  # one point done, for --resume; no temporary file
    assert after == before
    assert list(open_sweep(box / "s.h5").data["done"]) == [1, 0]


def test_a_failed_byte_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    old = tmp_path / "t.h5"
    old.write_bytes(b"the old file")
    _disk_full_at(monkeypatch, "table")
    with pytest.raises(OSError) as info:
        atomic.write_hdf5(old, lambda h5: h5.create_dataset("x", data=np.arange(1000)))
    assert info.value.errno == errno.ENOSPC
    assert old.read_bytes() == b"the old file" and os.listdir(tmp_path) == ["t.h5"]


@pytest.mark.parametrize("swallowed", [False, True], ids=["raised", "swallowed-by-h5py"])
def test_ctrl_c_during_the_write_keeps_the_old_table(box, capsys, monkeypatch, swallowed):
    """SIGINT while the file is written: exit 130, one line, old table and folder unchanged.

    ``swallowed`` replays what h5py's Cython code did with the KeyboardInterrupt of the
    default handler (it printed "Exception ignored" and carried on writing): the run must
    still notice the signal before it renames the file.
    """
    original = writer._write_material

    def interrupted(h5, material):
        if swallowed:
            try:
                signal.getsignal(signal.SIGINT)(signal.SIGINT, None)
            except KeyboardInterrupt:
                pass
        else:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # the handler runs at the next bytecode
        original(h5, material)

    monkeypatch.setattr(writer, "_write_material", interrupted)
    before = snapshot(box)
    status = _run_over_old()
    captured = capsys.readouterr()
    assert status == 130 and "Traceback" not in captured.err
    lines = [line for line in captured.err.splitlines() if "interrupt" in line]
    assert len(lines) == 1 and lines[0].startswith("vcavity: interrupted while writing old.h5: nothing written")
    after = snapshot(box)
    assert after.pop(str(box / "old.h5.checkpoint"))  # the finished run, for --resume
    assert after == before
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored


def test_not_enough_disk_or_memory_is_refused_with_the_figures(box, capsys, monkeypatch):
    from collections import namedtuple

    from vcavity.io import preflight

    before = snapshot(box)
    with monkeypatch.context() as patch:
        patch.setattr(preflight.shutil, "disk_usage", lambda path: namedtuple("Usage", "free")(1000))
        assert_refused(_run_over_old(), capsys.readouterr(), "--output = 'old.h5': the table needs up to "
                       "1.02 MB (uncompressed bound), only 0.000954 MB free in '.'", before, box)
    with monkeypatch.context() as patch:
        patch.setattr(preflight, "available_memory", lambda: 1000)
        # writing dominates: 11 arrays x 8 bytes x 2 directions x 4 orders x 81 cells = 57024 bytes,
        # plus the HDF5 image twice, each at most 8 x (3 x 2 x 4 x 81 + 8 x 81) + 2^20 = 1069312
        # bytes: 2195648 bytes = 2.09 MiB
        assert_refused(_run_over_old(["--threads", "1"]), capsys.readouterr(),
                       "simulation.sensor_resolution = 9 with max_order = 3: the run needs about 2.09 MB "
                       "of memory (1 thread(s) x 4 orders x 81 cells per tally, 2 direction(s)), 0.000954 MB "
                       "available", before, box)


# --- stale temporary files, --overwrite, integral floats ----------------------------------

def test_stale_temporaries_of_killed_runs_are_removed(box, capsys):
    dead = subprocess.Popen(["true"])
    dead.wait()  # a finished process: its pid names a writer that was killed
    host, old = atomic._HOST_TAG, time.time() - 2 * atomic.STALE_AGE_S
    other_host = "0" * 8 if host != "0" * 8 else "1" * 8
    files = {f".new.h5.{dead.pid}-{host}.{'a' * 12}.tmp": (None, True),  # writer gone
             f".new.h5.{os.getppid()}-{host}.{'b' * 12}.tmp": (None, False),  # writer alive
             f".new.h5.{'c' * 12}.tmp": (old, True),  # untagged (older versions), old
             f".new.h5.{'d' * 12}.tmp": (None, False),  # untagged, recent
             f".new.h5.{dead.pid}-{other_host}.{'e' * 12}.tmp": (old, True),  # other host, old
             f".new.h5.{dead.pid}-{other_host}.{'f' * 12}.tmp": (None, False),  # other host, recent
             f".other.h5.{dead.pid}-{host}.{'a' * 12}.tmp": (None, False),  # another table's
             "new.h5.tmp": (old, False)}  # not one of ours
    for name, (mtime, _) in files.items():
        (box / name).write_bytes(b"partial")
        if mtime is not None:
            os.utime(box / name, (mtime, mtime))
    assert _main(RUN) == 0
    err = capsys.readouterr().err
    assert "removed 3 stale temporary file(s)" in err
    assert {name for name in files if (box / name).exists()} == {n for n, (_, gone) in files.items() if not gone}
    assert atomic._temporary_pattern("x.h5").fullmatch(atomic.create_temporary(box / "x.h5").name)


def test_overwrite_replaces_and_integral_float_paths_are_counts(box, capsys):
    assert _main(["run", "c.toml", "-o", "old.h5", "--overwrite", "-q", "--paths", "2e3"]) == 0
    (box / "f.toml").write_text(toml({"incidence.paths": "2000.0"}))
    assert _main(["run", "f.toml", "-o", "f.h5", "-q"]) == 0
    capsys.readouterr()

    flag, toml_float = open_table(box / "old.h5"), open_table(box / "f.h5")
    assert list(flag.paths) == list(toml_float.paths) == [2000, 2000]
    assert np.array_equal(flag.counts, toml_float.counts)


def test_help_defaults_agree_with_the_config_defaults(capsys):
    from vcavity.config import default_config, validate

    assert _main(["run", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "theta_i_deg = [0] phi_i_deg = 0 paths = 10000000 (a config's defaults;" in text
    assert "the built-in run without CONFIG uses theta_i_deg = [0, 30, 60, 80]" in text
    assert "kd = 0.9 (albedo of the Lambertian body (0: specular dielectric); in [0, 1]; required)" in text
    cfg = validate({"material": {"alpha": 0.5, "kd": 0.5}})
    assert [d.theta_i_deg for d in cfg.incidence] == [0.0] and cfg.incidence[0].paths == 10_000_000
    assert [d.theta_i_deg for d in default_config().incidence] == [0.0, 30.0, 60.0, 80.0]


# --- corrupt tables in info and compare ---------------------------------------------------

@pytest.fixture(scope="module")
def good_table(tmp_path_factory):
    folder = tmp_path_factory.mktemp("table")
    (folder / "c.toml").write_text(toml())
    assert main(["run", str(folder / "c.toml"), "-o", str(folder / "t.h5"), "-q"]) == 0
    return folder / "t.h5"


CORRUPT = [("attr", "sensor_resolution", np.int64(-5), "attribute 'sensor_resolution' = -5 in "),
           ("attr", "sensor_resolution", "fifty-seven", "attribute 'sensor_resolution' = 'fifty-seven' in "),
           ("attr", "sensor_resolution", np.int64(10**9), "attribute 'sensor_resolution' = 1000000000 in "),
           ("attr", "n_cells", "many", "attribute 'n_cells' = 'many' in "),
           ("attr", "seed", np.int64(-1), "attribute 'seed' = -1 in "),
           ("data", "paths", 0, "dataset 'paths' = 0 at index 0 in "),
           ("data", "counts", -1, "dataset 'counts' = -1 at index (0, 0, 0) in "),
           ("data", "theta_i", 2.0, "dataset 'theta_i' = 2.0 at index 0 in ")]


@pytest.mark.parametrize("kind, name, value, expected", CORRUPT, ids=[f"{c[1]}={c[2]!r}" for c in CORRUPT])
def test_corrupt_tables_are_one_line_errors(good_table, tmp_path, capsys, kind, name, value, expected):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(good_table.read_bytes())
    with h5py.File(bad, "r+") as h5:
        if kind == "attr":
            h5.attrs[name] = value
        else:
            h5[name][...] = value
    for command in ("info", "compare"):
        status = _main([command, str(bad)])
        lines = capsys.readouterr().err.splitlines()
        assert status == 2 and len(lines) == 1 and expected in lines[0], (command, lines)


def test_a_huge_azimuth_keeps_the_summary_narrow(good_table, tmp_path, capsys):
    odd = tmp_path / "odd.h5"
    odd.write_bytes(good_table.read_bytes())
    with h5py.File(odd, "r+") as h5:  # a table from elsewhere: any finite phi_i is readable
        h5["phi_i"][...] = 1e300
        h5["phi_i_deg"][...] = np.degrees(1e300)  # the degrees must match the radians (open_table checks)
    assert _main(["info", str(odd)]) == 0
    out = capsys.readouterr().out
    assert "5.73e+301" in out and max(len(line) for line in out.splitlines()) < 140


# --- what a shell sees: subprocesses ------------------------------------------------------

def _cli(argv, cwd, **kwargs):
    return subprocess.Popen([sys.executable, "-m", "vcavity.cli", *argv], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def _refused_in_a_shell(box, argv, files, expected):
    _prepare(box, files)
    before = snapshot(box)
    proc = _cli(argv, box)
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise
    assert proc.returncode == 2 and out == "" and "Traceback" not in err, err
    assert len(err.splitlines()) == 1 and expected in err, err
    assert snapshot(box) == before


SHELL = ["kd-omitted", "seed-overflow", "symlink", *SHELL_ONLY]


@pytest.mark.parametrize("case", [c for c in CASES if c[0] in SHELL], ids=[c[0] for c in CASES if c[0] in SHELL])
def test_refused_in_a_shell(box, case):
    _refused_in_a_shell(box, *case[1:])


@pytest.mark.slow
@pytest.mark.parametrize("case", NEW_USER + FLAGS, ids=[c[0] for c in NEW_USER + FLAGS])
def test_refused_in_a_shell_every_case(box, case):
    if case[0] in ("proc", "sys") and not os.path.isdir(f"/{case[0]}"):
        pytest.skip("no such folder here")
    _refused_in_a_shell(box, *case[1:])


@pytest.fixture
def small_disk(tmp_path):
    """A 256 kB tmpfs (root only): a real disk that fills up."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


def _leave_free(folder, n_bytes):
    """Fill ``folder``'s file system (with real pages: tmpfs keeps no holes) up to ``n_bytes`` free."""
    usage = os.statvfs(folder)
    with open(folder / "filler", "ab") as filler:
        filler.write(b"\0" * max(0, usage.f_bavail * usage.f_frsize - n_bytes))


# the disk fills after the free-space check: something else wrote meanwhile
_NO_SPACE_CHECK = ("import sys; from vcavity.io import preflight; "
                   "preflight.check_disk_space = lambda out, needed: None; "
                   "from vcavity.cli import main; sys.exit(main(sys.argv[1:]))")


def test_a_disk_that_fills_up(small_disk, good_table):
    """On a real full disk: the table (55 kB) and then the checkpoint (15 kB) fail, each in one
    line naming it, exit 2, no temporary file, old files unchanged; --resume then finishes."""
    (small_disk / "c.toml").write_text(toml())
    (small_disk / "old.h5").write_bytes(b"an older table\n" * 64)

    def run(*flags):
        done = subprocess.run([sys.executable, "-c", _NO_SPACE_CHECK, "run", "c.toml", "-o", "old.h5", "-q",
                               "--overwrite", *flags], cwd=small_disk, capture_output=True, text=True)
        assert "Traceback" not in done.stderr and "HDF5" not in done.stderr, done.stderr
        return done.returncode, [line for line in done.stderr.splitlines() if "error" in line]

    _leave_free(small_disk, 32 * 1024)
    before = snapshot(small_disk)
    status, error = run()
    assert status == 2 and len(error) == 1, error
    assert "--output = 'old.h5': writing the table failed (No space left on device)" in error[0]
    after = snapshot(small_disk)
    kept = after.pop(str(small_disk / "old.h5.checkpoint"))
    assert after == before
    _leave_free(small_disk, 8 * 1024)
    before = snapshot(small_disk)
    status, error = run("--resume")
    assert status == 2 and len(error) == 1, error
    assert error[0].endswith("writing the checkpoint 'old.h5.checkpoint' failed (No space left on device); no "
                             "table written, an existing file is unchanged; the previous checkpoint is unchanged")
    assert snapshot(small_disk) == before and before[str(small_disk / "old.h5.checkpoint")] == kept
    (small_disk / "filler").unlink()
    assert run("--resume") == (0, [])
    assert np.array_equal(open_table(small_disk / "old.h5").counts, open_table(good_table).counts)


def test_a_sweep_on_a_full_disk(small_disk):
    (small_disk / "s.toml").write_text(toml({"incidence.theta_i_deg": None}, "[sweep]\nalpha = [0.3, 0.6]\n"
                                                                            "theta_i_deg = [0]\n"))
    _leave_free(small_disk, 8 * 1024)
    before = snapshot(small_disk)
    done = subprocess.run([sys.executable, "-c", _NO_SPACE_CHECK, "sweep", "s.toml", "-o", "s.h5", "-q"],
                          cwd=small_disk, capture_output=True, text=True)
    error = [line for line in done.stderr.splitlines() if "error" in line]
    assert done.returncode == 2 and "Traceback" not in done.stderr and "HDF5" not in done.stderr, done.stderr
    assert error == ["vcavity: error: --output = 's.h5': writing the sweep failed (No space left on device); "
                     "nothing was written"]
    assert snapshot(small_disk) == before


def _interrupt(argv, cwd, wait_for, delay, env=None):
    """Start the CLI in its own process group, SIGINT it ``delay`` s after a stderr line."""
    proc = _cli(argv, cwd, start_new_session=True, env=env)
    seen = []
    for line in proc.stderr if wait_for is not None else ():
        seen.append(line)
        if wait_for in line:
            break
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=300)
    return proc.returncode, "".join(seen) + err


def test_ctrl_c_mid_run(box):
    before = snapshot(box)
    status, err = _interrupt(["run", "c.toml", "-o", "old.h5", "--overwrite", "-q", "--paths", "1e9",
                              "--chunk-blocks", "8"], box, "kernel ready", 0.3)
    assert status == 130 and "Traceback" not in err and "SystemError" not in err, err
    assert err.splitlines()[-1].startswith("vcavity: interrupted; checkpoint old.h5.checkpoint saved (")
    after = snapshot(box)
    assert after.pop(str(box / "old.h5.checkpoint"))  # progress kept, the old table untouched
    assert after == before


@pytest.mark.slow
@pytest.mark.parametrize("command", ["run", "compare"])
def test_ctrl_c_while_compiling(box, good_table, tmp_path_factory, command):
    """A cold Numba cache: compiling takes many seconds, SIGINT lands in it."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path_factory.mktemp("cold-cache"))}
    argv = ["run", "c.toml", "-o", "new.h5", "-q"] if command == "run" else ["compare", str(good_table)]
    before = snapshot(box)
    status, err = _interrupt(argv, box, "direction(s)" if command == "run" else None, 2.0, env)
    assert status == 130 and "Traceback" not in err, err
    assert "kernel ready" not in err  # it was still compiling
    expected = "vcavity: interrupted; no table written" if command == "run" else "vcavity: interrupted"
    assert err.splitlines()[-1] == expected
    assert snapshot(box) == before


class _Exited(Exception):
    pass


@pytest.mark.parametrize("status", [0, 1, 2, 130, 143])
def test_console_entry_skips_teardown_whatever_the_status(monkeypatch, status):
    """The console entry ends with os._exit, with the late signals' handler in place: no
    teardown of half-built llvmlite objects after Ctrl-C (which once crashed with SIGSEGV),
    and none after a finished command either, during which signals have their default
    actions again (issue 38 trial: a SIGTERM there ended a finished run with 143, no line)."""
    import vcavity.cli as cli_package

    calls = []
    monkeypatch.setattr(cli_package, "main", lambda: status)
    handlers = {}

    def fake_exit(code):
        calls.append(code)
        handlers.update({signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)})
        raise _Exited

    monkeypatch.setattr(cli_package.os, "_exit", fake_exit)
    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        with pytest.raises(_Exited):
            cli_package.console_main()
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    assert calls == [status]
    assert all(handler is cli_package._late_interrupt for handler in handlers.values()), handlers


def test_a_finished_command_has_no_teardown(tmp_path):
    """What the process would run at its teardown (an atexit hook here) never runs: the
    command's status is its exit status, with nothing after it to be killed in."""
    code = ("import atexit, sys; atexit.register(lambda: print('teardown ran', flush=True)); "
            "sys.argv = ['vcavity', 'warmup', '--all', '--list']; from vcavity.cli import console_main; console_main()")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "teardown ran" not in done.stdout and "ggx" in done.stdout


def test_an_interrupt_between_a_compile_and_its_notice_ends_the_line_first(tmp_path, capsys, monkeypatch):
    """Issue 38 trial: 'compiling the kernel ... ...vcavity: interrupted; no table written' on
    one line, when the Ctrl-C struck after the notice's line was written and before it ended."""
    import vcavity.cli.info as info_command
    from vcavity.simulate.warmup import CompileNotice

    notices = []

    def compiling_then_interrupted(args):
        notice = CompileNotice("ggx x interfaced_lambertian", delay=0.0, cached=True)
        notices.append(notice)
        notice.__enter__()
        notice._compiling.set()  # as Numba's compile event does
        deadline = time.monotonic() + 30
        while not notice._shown and time.monotonic() < deadline:
            time.sleep(0.01)
        raise KeyboardInterrupt  # its __exit__ never runs

    monkeypatch.setattr(info_command, "command", compiling_then_interrupted)
    try:
        assert main(["info", str(tmp_path / "t.h5")]) == 130
    finally:
        for notice in notices:  # its thread and Numba event listener
            notice.__exit__(None, None, None)
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["vcavity: compiling the kernel for ggx x interfaced_lambertian (first use; cached afterwards) "
                     "... stopped", "vcavity: interrupted"], lines
