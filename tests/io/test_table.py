"""Tests of writing and reading HDF5 tables (vcavity.io.table, vcavity.io.writer).

All checks here are exact or rounding-level comparisons on random but internally
consistent integer counts drawn with fixed seeds (tests/io/conftest.py): nothing is
statistical, so there is no false-positive rate to state. The file layout is checked in
test_table_layout.py, netCDF/xarray reading in test_table_netcdf.py, format v1 in
test_table_v1.py.
"""

import os
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

import vcavity
from vcavity.io import writer as writer_module
from vcavity.io.table import FORMAT_VERSION, Table, TableFormatError, open_table
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.sensor.binning import cell_index

EPS = np.finfo(np.float64).eps


def test_round_trip_values(written, sensor, material, config):
    path, run = written
    table = open_table(path)
    assert isinstance(table, Table)
    for name in ("theta_i", "phi_i", "order", "counts", "paths", "max_bounces_seen"):
        np.testing.assert_array_equal(getattr(table, name), run[name], err_msg=name)
    assert table.counts.dtype == np.int64 and table.paths.dtype == np.int64
    assert table.brdf.dtype == np.float64 and table.brdf.shape == run["counts"].shape
    for name in ("absorbed", "truncated", "degenerate"):
        np.testing.assert_array_equal(getattr(table, name), run[f"{name}_paths"] / run["paths"])
    np.testing.assert_array_equal(table.cell_center, sensor.cell_center)
    np.testing.assert_array_equal(table.cell_solid_angle, sensor.cell_solid_angle)
    np.testing.assert_array_equal(table.cell_projected_solid_angle,
                                  sensor.cell_projected_solid_angle)
    assert table.material == {k: v for k, v in material.items() if v is not None}
    assert table.config == config
    assert table.seed == 7 and table.format_version == FORMAT_VERSION == 3
    assert table.vcavity_version == vcavity.__version__
    assert table.attrs["block_size"] == 4096 and table.attrs["max_bounces"] == 1000
    assert table.attrs["compute_time_s"] == 1.5 and table.attrs["compile_time_s"] == 0.25
    assert table.attrs["sensor_resolution"] == 5 and table.attrs["n_cells"] == 25
    assert table.path == path
    # without theta_i_deg/phi_i_deg the degrees are np.degrees of the radians
    np.testing.assert_array_equal(table.theta_i_deg, np.degrees(run["theta_i"]))
    np.testing.assert_array_equal(table.phi_i_deg, np.degrees(run["phi_i"]))
    np.testing.assert_array_equal(table.theta_o, sensor.cell_theta)
    np.testing.assert_array_equal(table.phi_o, sensor.cell_phi)
    for name in ("brdf", "theta_i_deg", "phi_i_deg", "theta_o", "phi_o", "counts"):
        assert not getattr(table, name).flags.writeable, name  # a frozen table: read-only arrays


def test_user_degrees_are_stored_as_given(tmp_path, sensor, consistent_run, write):
    """theta_i_deg = 60 is stored as 60.0, not as degrees(radians(60)) = 59.99999999999999."""
    run = consistent_run(8, sensor, n_incidence=3)
    theta_deg, phi_deg = [0.0, 60.0, 89.9], [0.0, 45.0, -120.0]
    run.update(theta_i=np.radians(theta_deg), phi_i=np.radians(phi_deg))
    assert np.degrees(np.radians(60.0)) != 60.0  # the round trip does lose the user's number
    write(tmp_path / "t.h5", run, sensor, theta_i_deg=theta_deg, phi_i_deg=phi_deg)
    table = open_table(tmp_path / "t.h5")
    assert table.theta_i_deg.tolist() == theta_deg and table.phi_i_deg.tolist() == phi_deg
    np.testing.assert_array_equal(table.theta_i, np.radians(theta_deg))
    with h5py.File(tmp_path / "t.h5", "r") as h5:
        assert h5["theta_i_deg"][()].tolist() == theta_deg
        assert h5["phi_i_deg"][()].tolist() == phi_deg


def test_degrees_must_match_radians(tmp_path, sensor, consistent_run, write):
    run = consistent_run(9, sensor, n_incidence=2)
    good = np.degrees(run["theta_i"])
    with pytest.raises(ValueError, match="dataset 'theta_i_deg' .* must be finite and equal theta_i in degrees"):
        write(tmp_path / "t.h5", run, sensor, theta_i_deg=good + [0.0, 1e-6])
    with pytest.raises(ValueError, match="dataset 'phi_i_deg' .* must be finite and equal phi_i in degrees"):
        write(tmp_path / "t.h5", run, sensor, phi_i_deg=np.degrees(run["phi_i"]) + 360.0)
    with pytest.raises(ValueError, match=r"dataset 'theta_i_deg' has shape \(1,\), expected \(2,\)"):
        write(tmp_path / "t.h5", run, sensor, theta_i_deg=good[:1])
    assert os.listdir(tmp_path) == []


def test_large_seed_and_material_value_types(tmp_path, sensor, consistent_run, write, material):
    """Seeds up to 2**64 - 1 are uint64; booleans become int8 0/1 (netCDF drops enums)."""
    run = consistent_run(10, sensor, n_incidence=1)
    extra = dict(material, flag=True, off=np.bool_(False), count=3, huge=2**63 + 1, name="x")
    write(tmp_path / "t.h5", run, sensor, seed=2**64 - 1, material=extra)
    table = open_table(tmp_path / "t.h5")
    assert table.seed == 2**64 - 1
    assert table.material["flag"] == 1 and table.material["off"] == 0
    assert table.material["count"] == 3 and table.material["huge"] == 2**63 + 1
    with h5py.File(tmp_path / "t.h5", "r") as h5:
        assert h5.attrs["seed"].dtype == np.uint64
        assert h5["material"].attrs["flag"].dtype == np.int8
        assert h5["material"].attrs["huge"].dtype == np.uint64
    write(tmp_path / "t.h5", run, sensor, seed=2**63 - 1)
    with h5py.File(tmp_path / "t.h5", "r") as h5:
        assert h5.attrs["seed"].dtype == np.int64
    for bad_seed in (2**64, -1):
        with pytest.raises(ValueError, match="seed must be an integer in"):
            write(tmp_path / "u.h5", run, sensor, seed=bad_seed)
    with pytest.raises(TypeError, match=r"material\['list'\]"):
        write(tmp_path / "u.h5", run, sensor, material=dict(material, list=[1, 2]))
    assert sorted(os.listdir(tmp_path)) == ["t.h5"]


def test_derived_quantities_match_plain_numpy(written):
    """brdf, stderr and albedo against a loop over cells (physics.md sec. 6)."""
    path, run = written
    table = open_table(path)
    counts, paths, proj = run["counts"], run["paths"], table.cell_projected_solid_angle
    brdf = np.empty(counts.shape)
    stderr = np.empty(counts.shape)
    for i in range(counts.shape[0]):
        for k in range(counts.shape[1]):
            for c in range(counts.shape[2]):
                p = counts[i, k, c] / paths[i]  # multinomial cell probability
                brdf[i, k, c] = p / proj[c]
                stderr[i, k, c] = np.sqrt(paths[i] * p * (1.0 - p)) / (paths[i] * proj[c])
    albedo = (brdf * proj).sum(axis=2)  # sum_c brdf * Ω⊥_c
    np.testing.assert_allclose(table.brdf, brdf, rtol=1e-14, atol=0)
    np.testing.assert_allclose(table.brdf_stderr, stderr, rtol=1e-13, atol=0)
    np.testing.assert_allclose(table.albedo, albedo, rtol=1e-13, atol=0)
    assert np.all(table.brdf[table.counts == 0] == 0.0)


def test_bookkeeping_closes(written):
    """albedo(order 0) + absorbed + truncated + degenerate = 1.

    Exact in integers; the stored floats are each correctly rounded quotients, so their sum
    can differ from 1 by a few ulp only.
    """
    path, run = written
    table = open_table(path)
    j = table.order_index(0)
    recovered = {name: np.rint(getattr(table, name) * table.paths).astype(np.int64)
                 for name in ("absorbed", "truncated", "degenerate")}
    np.testing.assert_array_equal(recovered["absorbed"], run["absorbed_paths"])
    exits = table.counts[:, j, :].sum(axis=1)
    np.testing.assert_array_equal(exits + sum(recovered.values()), table.paths)
    total = table.albedo[:, j] + table.absorbed + table.truncated + table.degenerate
    np.testing.assert_allclose(total, 1.0, rtol=0, atol=4 * EPS)
    # Orders 1..K never exceed f_inf in any cell.
    assert np.all(table.counts[:, 1:, :].sum(axis=1) <= table.counts[:, j, :])


def test_without_order_zero(tmp_path, sensor, consistent_run, write):
    run = consistent_run(5, sensor, with_all_orders=False)
    write(tmp_path / "t.h5", run, sensor)
    table = open_table(tmp_path / "t.h5")
    np.testing.assert_array_equal(table.order, [1, 2, 3])
    assert table.order_index(1) == 0 and table.order_index(3) == 2
    with pytest.raises(ValueError, match="order 0 is not in table"):
        table.order_index(0)
    total = table.albedo.sum(axis=1) + table.absorbed + table.truncated + table.degenerate
    np.testing.assert_allclose(total, 1.0, rtol=0, atol=8 * EPS)


def test_order_index(written):
    table = open_table(written[0])
    assert [table.order_index(k) for k in (0, 1, 2, 3)] == [0, 1, 2, 3]
    with pytest.raises(ValueError, match=r"order 4 is not in table .*orders present: 0, 1, 2, 3"):
        table.order_index(4)


def test_sensor_rebuilt_bins_cell_centres(written, sensor):
    table = open_table(written[0])
    assert isinstance(table.sensor, EqualAreaSensor)
    assert table.sensor.resolution == sensor.resolution
    assert table.sensor.partition == table.attrs["sensor_partition"] == sensor.partition
    np.testing.assert_array_equal(cell_index(table.sensor, table.cell_center),
                                  np.arange(sensor.n_cells))


def test_write_replaces_existing_file(written, sensor, consistent_run, write):
    path, _ = written
    other = consistent_run(99, sensor, n_incidence=2)
    write(path, other, sensor, seed=123)
    table = open_table(path)
    assert table.seed == 123
    np.testing.assert_array_equal(table.counts, other["counts"])
    assert os.listdir(path.parent) == [path.name]


def test_failed_write_leaves_existing_file_untouched(written, sensor, monkeypatch, consistent_run,
                                                   write):
    path, _ = written
    before = path.read_bytes()

    def fail_midway(h5, material):
        raise RuntimeError("disk on fire")

    # _write_material runs after all datasets are in the temporary file.
    monkeypatch.setattr(writer_module, "_write_material", fail_midway)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write(path, consistent_run(3, sensor), sensor)
    assert path.read_bytes() == before
    assert os.listdir(path.parent) == [path.name]  # no temporary file left behind
    with pytest.raises(RuntimeError):
        write(path.parent / "new.h5", consistent_run(3, sensor), sensor)
    assert os.listdir(path.parent) == [path.name]


def test_what_a_reader_refuses_is_not_written(tmp_path, sensor, consistent_run, write):
    """The writer checks a table value as open_table checks a file (io/checks.py): each
    defect is a one-line ValueError naming the dataset, and nothing is written."""
    run = consistent_run(11, sensor)
    defects = [
        (run, {"tabulated": {"counts": run["counts"][:, :, :-1]}}, r"dataset 'counts' has shape"),
        (run, {"tabulated": {"order": [0, 2, 3, 4]}}, "dataset 'order' .* must be 1..K or 0, 1..K"),
        (dict(run, paths=np.zeros_like(run["paths"])), {}, "dataset 'paths' = 0 .* must be >= 1"),
        (run, {"tabulated": {"brdf": np.full(run["counts"].shape, np.nan)}}, "dataset 'brdf' = nan"),
        (run, {"tabulated": {"albedo": 2 * run["counts"].sum(axis=2) / run["paths"][:, None]}}, "dataset 'albedo'"),
        (run, {"run_attrs": {"deterministic": 1}}, r"dataset 'paths' .* \(a deterministic table traced none\)"),
        (run, {"run_attrs": {"estimator": ""}}, "attribute 'estimator' = '' .* must name an estimator"),
    ]
    for defective, options, match in defects:
        with pytest.raises(ValueError, match=match) as info:
            write(tmp_path / "t.h5", defective, sensor, **options)
        assert "\n" not in str(info.value)
    assert os.listdir(tmp_path) == []


def _single_line_error(path, match):
    with pytest.raises(TableFormatError, match=match) as info:
        open_table(path)
    assert "\n" not in str(info.value)
    return str(info.value)


def test_not_an_hdf5_file(tmp_path):
    path = tmp_path / "notes.h5"
    path.write_text("just text\n")
    _single_line_error(path, "not a vcavity table: ")


def test_foreign_hdf5_file(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as h5:
        h5["brdf"] = np.zeros(3)
    message = _single_line_error(path, "not a vcavity table: ")
    assert message == f"not a vcavity table: {path}"


def test_missing_dataset(written):
    path, _ = written
    with h5py.File(path, "a") as h5:
        del h5["brdf"]
    message = _single_line_error(path, "missing dataset 'brdf'")
    assert message == f"missing dataset 'brdf' in {path}"


def test_unsupported_version(written):
    path, _ = written
    with h5py.File(path, "a") as h5:
        h5.attrs["format_version"] = 4
    message = _single_line_error(path, "unsupported format_version")
    assert message == f"unsupported format_version 4 in {path} (this vcavity reads 1, 2, 3)"


def test_inconsistent_shape(written):
    path, _ = written
    with h5py.File(path, "a") as h5:
        del h5["paths"]
        h5["paths"] = np.ones(7, dtype=np.int64)
    _single_line_error(path, r"dataset 'paths' has shape \(7,\), expected \(3,\)")


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        open_table(tmp_path / "absent.h5")


def test_table_error_is_a_value_error():
    assert issubclass(TableFormatError, ValueError)


DOCS = Path(__file__).resolve().parents[2] / "docs" / "hdf5-format.md"


def test_documentation_snippets_run(tmp_path, sensor, consistent_run, write):
    """The ```python blocks of docs/hdf5-format.md run, in order, against a real table."""
    path = tmp_path / "table.h5"
    run = consistent_run(2025, sensor)
    degrees = {"theta_i_deg": [0.0, 30.0, 60.0], "phi_i_deg": [0.0, 0.0, 45.0]}
    run.update(theta_i=np.radians(degrees["theta_i_deg"]), phi_i=np.radians(degrees["phi_i_deg"]))
    write(path, run, sensor, **degrees)
    text = DOCS.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 4
    namespace = {"path": path}
    for block in blocks:
        exec(compile(block, str(DOCS), "exec"), namespace)  # noqa: S102 - our own docs
    # The documented plain-NumPy binning agrees with the sensor on random directions.
    rng = np.random.default_rng(17)
    directions = rng.normal(size=(20_000, 3))
    directions[:, 2] = np.abs(directions[:, 2])
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions = np.vstack([directions, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]])
    np.testing.assert_array_equal(namespace["cell_index"](directions, sensor.resolution),
                                  cell_index(sensor, directions))
