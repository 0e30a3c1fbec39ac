"""Sweep points committed in place (docs/sweeps.md, "Writing, interrupting, resuming"): a
commit changes only the point's own bytes, a kill -9 at any moment of it leaves a valid
file with that point not done, a point whose bytes changed (checksum mismatch) is read as
not done and resumed, and a reader sees a consistent file while a point is written.

The grid puts theta_i_deg first, so a point's values are not one block of each dataset
(two runs per variable). Every comparison is of stored values, bit for bit (the checksum
reference, tests/io/checksum_reference.py, is written from the docs with h5py and
hashlib): nothing statistical. Kernel: the beckmann + interfaced_lambertian variant
test_sweep.py compiles.
"""

import os
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from tests.export.synthetic_sweeps import synthetic_sweep
from tests.io.checksum_reference import checksums
from tests.sweep.test_run import BASE, _same_file, _write
from vcavity.cli import main
from vcavity.io import sweep_points
from vcavity.io.sweep_table import open_sweep
from vcavity.sweep import run as sweep_run
from vcavity.sweep import spec as sweep_mod

GRID = "[sweep]\ntheta_i_deg = [0, 60]\nalpha = [0.3, 0.6]\neta = [1.3, 1.5]\n"
POINT_AXES = (1, 2)  # alpha, eta among the grid axes (theta_i_deg, alpha, eta)


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    """An uninterrupted sweep: (folder, sweep file, output)."""
    folder = tmp_path_factory.mktemp("commit")
    spec = _write(folder, "grid.toml", BASE + GRID)
    out = folder / "full.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q"]) == 0
    return folder, spec, out


def _point_bytes(path, index):
    """Byte ranges of point ``index`` (alpha, eta) in the file: per dataset on the point axes,
    from h5py's dataset offsets and C order (independent of vcavity's writer)."""
    owned = []
    with h5py.File(path, "r") as h5:
        for name, dataset in h5.items():
            if not isinstance(dataset, h5py.Dataset) or dataset.ndim < 2 or name in ("cell_center",):
                continue
            if dataset.ndim >= 3:  # (theta_i_deg, alpha, eta, ...)
                where = (slice(None), index[0], index[1])
            else:  # on the point axes: seed, done, compute_time_s, checksum
                where = index
            flat = np.arange(dataset.size).reshape(dataset.shape)[where].ravel()
            start = dataset.id.get_offset() + flat * dataset.dtype.itemsize
            owned += [(int(s), int(s) + dataset.dtype.itemsize) for s in start]
    return owned


def test_a_commit_changes_only_the_points_own_bytes(full, tmp_path):
    folder, spec, _ = full
    out = tmp_path / "steps.h5"
    sweep = sweep_mod.load(spec)
    _, data, _ = sweep_run.plan_output(sweep, str(out), str(spec))
    images = []
    sweep_run.run(sweep, out, data, on_point=lambda point, d: images.append((point.index, out.read_bytes())))
    assert len(images) == 4
    for (_, before), (index, after) in zip(images, images[1:]):
        assert len(after) == len(before)  # nothing allocated: the file was complete from the first point
        changed = np.flatnonzero(np.frombuffer(before, np.uint8) != np.frombuffer(after, np.uint8))
        assert changed.size > 0
        inside = np.zeros(len(after), bool)
        for start, end in _point_bytes(out, index):
            inside[start:end] = True
        assert inside[changed].all(), f"point {index}: bytes outside its values changed (HDF5 metadata?)"
    with h5py.File(out, "r") as h5:  # the stored checksums are those of the documented recipe
        np.testing.assert_array_equal(h5["checksum"][()], checksums(h5))


# kill -9 at the N-th in-place piece write of the run (the first point writes the whole file,
# so the second point's commit is pieces 1..17: 15 variables of values, checksum, done;
# each of the 13 grid variables in 2 runs): the piece is half written, then SIGKILL
_KILLER = """
import os, signal, sys
from vcavity.io import sweep_points
real, calls, kill_at = sweep_points.write_at, [], int(sys.argv[1])
def write_at(fd, data, offset):
    calls.append(offset)
    if len(calls) == kill_at:
        real(fd, data[: len(data) // 2], offset)
        os.kill(os.getpid(), signal.SIGKILL)
    real(fd, data, offset)
sweep_points.write_at = write_at
from vcavity.cli import main
sys.exit(main(sys.argv[2:]))
"""
PIECES = 13 * 2 + 2  # values: 13 grid variables in 2 runs each, seed, compute_time_s


@pytest.mark.parametrize("kill_at, moment", [(7, "among the values"), (PIECES, "in the last value"),
                                             (PIECES + 1, "in the checksum"), (PIECES + 2, "at the done flag")])
def test_kill_9_during_a_points_write_then_resume(full, tmp_path, kill_at, moment):
    folder, spec, reference = full
    out = tmp_path / "killed.h5"
    proc = subprocess.run([sys.executable, "-c", _KILLER, str(kill_at), "sweep", str(spec), "-o", str(out), "-q"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    read = open_sweep(out)  # a valid file: HDF5 metadata untouched, the torn point not done
    assert read.data["done"].tolist() == [[1, 0], [0, 0]] and read.rejected == ()
    assert np.isnan(read.data["brdf"][:, 0, 1]).all() and (read.data["counts"][:, 0, 1] == 0).all()
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.done.values.tolist() == [[1, 0], [0, 0]]
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--resume"]) == 0
    _same_file(reference, out)
    assert sorted(os.listdir(tmp_path)) == ["killed.h5"]


def test_a_point_whose_bytes_changed_is_read_as_not_done_and_run_again(full, tmp_path, capsys):
    folder, spec, reference = full
    out = tmp_path / "damaged.h5"
    out.write_bytes(reference.read_bytes())
    with h5py.File(reference, "r") as h5:  # one count of point (alpha 0.6, eta 1.3) flipped on disk
        counts = h5["counts"]
        position = counts.id.get_offset() + np.ravel_multi_index((1, 1, 0, 1, 40), counts.shape) * 8
    with open(out, "r+b") as stream:
        stream.seek(position)
        value = int.from_bytes(stream.read(8), "little")
        stream.seek(position)
        stream.write((value ^ 1).to_bytes(8, "little"))
    read = open_sweep(out)  # still a plausible value: only the checksum tells
    assert read.rejected == ((1, 0),) and read.data["done"].tolist() == [[1, 1], [0, 1]]
    assert np.isnan(read.data["brdf"][:, 1, 0]).all()
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert "points: 3 of 4 done" in info and "1 point(s) marked done fail their checksum" in info
    traced = []
    sweep = sweep_mod.load(spec)
    _, data, note = sweep_run.plan_output(sweep, str(out), str(spec), resume=True)
    assert "1 point(s) marked done fail their checksum" in note
    sweep_run.run(sweep, out, data, on_progress=lambda paths, error: traced.append(paths))
    assert sum(traced) == 2 * 20_000  # only that point's two directions
    _same_file(reference, out)


def test_reading_while_a_point_is_written(full, tmp_path, monkeypatch):
    """A reader at each piece of the second point's commit (same file, same moment as another
    process would see it): the first point done, the second pending until its done flag."""
    folder, spec, reference = full
    out = tmp_path / "live.h5"
    real, seen = sweep_points.write_at, []

    def write_at(fd, data, offset):
        real(fd, data, offset)
        if len(seen) < PIECES + 2:
            read = open_sweep(out)
            with xr.open_dataset(out, engine="h5netcdf") as ds:
                albedo = ds.albedo.sel(alpha=0.3, eta=1.3).values
            seen.append((read.data["done"].tolist(), np.isnan(read.data["albedo"][:, 0, 1]).all(), albedo))

    monkeypatch.setattr(sweep_points, "write_at", write_at)
    sweep = sweep_mod.load(spec)
    _, data, _ = sweep_run.plan_output(sweep, str(out), str(spec))
    sweep_run.run(sweep, out, data)
    with h5py.File(reference, "r") as h5:
        first = h5["albedo"][:, 0, 0]
    assert len(seen) == PIECES + 2
    for done, pending_nan, albedo in seen[:-1]:
        assert done == [[1, 0], [0, 0]] and pending_nan
        np.testing.assert_array_equal(albedo, first)
    assert seen[-1][0] == [[1, 1], [0, 0]] and not seen[-1][1]
    _same_file(reference, out)


def test_a_file_written_before_in_place_commits_is_read_and_resumed(full, tmp_path):
    """tests/io/data/sweep_before_commits.h5: this sweep's first point, written by vcavity at
    e091c4d (gzip-chunked, no checksum; make_sweep_before_commits.py). Its done flags are
    trusted; --resume writes it whole once in the new layout, then goes on in place."""
    folder, spec, reference = full
    out = tmp_path / "old.h5"
    out.write_bytes((Path(__file__).parents[1] / "io" / "data" / "sweep_before_commits.h5").read_bytes())
    with h5py.File(out, "r") as h5:
        assert "checksum" not in h5 and h5["brdf"].compression == "gzip"
    read = open_sweep(out)
    assert read.data["done"].tolist() == [[1, 0], [0, 0]] and read.rejected == ()
    with h5py.File(reference, "r") as h5:
        np.testing.assert_array_equal(read.data["counts"][:, 0, 0], h5["counts"][:, 0, 0])
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.done.values.tolist() == [[1, 0], [0, 0]]
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--resume"]) == 0
    _same_file(reference, out)
    with h5py.File(out, "r") as h5:
        assert h5["brdf"].compression is None and h5["brdf"].chunks is None


def test_resume_never_writes_a_file_that_changed_after_it_was_read(full, tmp_path):
    folder, spec, reference = full
    out = tmp_path / "swapped.h5"
    out.write_bytes((Path(__file__).parents[1] / "io" / "data" / "sweep_before_commits.h5").read_bytes())
    sweep = sweep_mod.load(spec)
    _, data, _ = sweep_run.plan_output(sweep, str(out), str(spec), resume=True)
    other = synthetic_sweep(tmp_path / "other.h5", [("alpha", [0.2, 0.5]), ("theta_i_deg", [0.0, 40.0])],
                            lambda coords, k: 0.5 / (k + 1), pending=[{"alpha": 0.5}])
    os.replace(other, out)  # another sweep now sits where --resume read its file
    before = out.read_bytes()
    with pytest.raises(OSError, match=r"changed since it was read \(its attribute spec_digest is 'synthetic'"):
        sweep_run.run(sweep, out, data)
    assert out.read_bytes() == before
