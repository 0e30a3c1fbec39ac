"""Tests of the HDF5 table format v1 (vcavity.io.table).

All checks here are exact or rounding-level comparisons on random but internally
consistent integer counts drawn with fixed seeds: nothing is statistical, so there is
no false-positive rate to state.
"""

import json
import os
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

import vcavity
from vcavity.io import table as table_module
from vcavity.io.table import FORMAT_VERSION, Table, TableFormatError, open_table, write_table
from vcavity.sensor import EqualAreaSensor

EPS = np.finfo(np.float64).eps
MATERIAL = {"distribution": "beckmann", "facet": "interfaced_lambertian", "kd": 0.9,
            "eta": 1.5, "alpha_x": 0.3, "alpha_y": 0.5, "exponent": None}
CONFIG = {"material": {"distribution": "beckmann", "alpha_x": 0.3, "alpha_y": 0.5},
          "simulation": {"seed": 7, "max_order": 3}, "incidence": {"theta_i": [0.0, 0.5, 1.2]}}


def consistent_run(seed, sensor, n_incidence=3, max_order=3, with_all_orders=True):
    """Random integer counts obeying the bookkeeping of an analog walk (physics.md sec. 6).

    Every path is exactly one of: exits with order 1..K, exits with order > K,
    absorbed, truncated, degenerate. Order 0 (if kept) counts every exit.
    """
    rng = np.random.default_rng(seed)
    n_cells = sensor.n_cells
    paths = rng.integers(1_000, 50_000, size=n_incidence)
    n_orders = max_order + (1 if with_all_orders else 0)
    counts = np.zeros((n_incidence, n_orders, n_cells), dtype=np.int64)
    lost = np.zeros((3, n_incidence), dtype=np.int64)
    for i in range(n_incidence):
        shares = rng.dirichlet(np.ones(max_order + 4))
        split = rng.multinomial(paths[i], shares)  # orders 1..K, order > K, 3 losses
        per_order = [rng.multinomial(split[k], rng.dirichlet(np.ones(n_cells)))
                     for k in range(max_order + 1)]
        first = 1 if with_all_orders else 0
        for k in range(max_order):
            counts[i, first + k] = per_order[k]
        if with_all_orders:
            counts[i, 0] = np.sum(per_order, axis=0)
        lost[:, i] = split[max_order + 1:]
    if not with_all_orders:  # without f_inf, paths beyond K count as truncated
        lost[1] += paths - counts.sum(axis=(1, 2)) - lost.sum(axis=0)
    order = np.arange(0 if with_all_orders else 1, max_order + 1)
    return dict(
        theta_i=rng.uniform(0.0, 0.5 * np.pi, n_incidence),
        phi_i=rng.uniform(-np.pi, np.pi, n_incidence),
        order=order, counts=counts, paths=paths,
        absorbed_paths=lost[0], truncated_paths=lost[1], degenerate_paths=lost[2],
        max_bounces_seen=rng.integers(max_order, 500, n_incidence),
    )


def write(path, run, sensor, **overrides):
    arguments = dict(run, sensor=sensor, material=MATERIAL, config=CONFIG, seed=7,
                     block_size=4096, max_bounces=1000, compute_time_s=1.5,
                     compile_time_s=0.25)
    arguments.update(overrides)
    write_table(path, **arguments)


@pytest.fixture(scope="module")
def sensor():
    return EqualAreaSensor(5)


@pytest.fixture
def written(tmp_path, sensor):
    run = consistent_run(2024, sensor)
    path = tmp_path / "table.h5"
    write(path, run, sensor)
    return path, run


def test_round_trip_values(written, sensor):
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
    assert table.material == {k: v for k, v in MATERIAL.items() if v is not None}
    assert table.config == CONFIG
    assert table.seed == 7 and table.format_version == FORMAT_VERSION == 1
    assert table.vcavity_version == vcavity.__version__
    assert table.attrs["block_size"] == 4096 and table.attrs["max_bounces"] == 1000
    assert table.attrs["compute_time_s"] == 1.5 and table.attrs["compile_time_s"] == 0.25
    assert table.attrs["sensor_resolution"] == 5 and table.attrs["n_cells"] == 25
    assert table.path == path
    assert not table.brdf.flags.writeable  # a frozen table holds read-only arrays


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


def test_without_order_zero(tmp_path, sensor):
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
    np.testing.assert_array_equal(table.sensor.cell_index(table.cell_center),
                                  np.arange(sensor.n_cells))


def test_dimension_scales(written):
    with h5py.File(written[0], "r") as h5:
        for name in ("brdf", "brdf_stderr", "counts"):
            dims = h5[name].dims
            assert [d.label for d in dims] == ["incidence", "order", "cell"]
            assert list(dims[0].keys()) == ["theta_i", "phi_i"]
            assert list(dims[1].keys()) == ["order"]
            assert list(dims[2].keys()) == ["cell"]
        assert [d.label for d in h5["albedo"].dims] == ["incidence", "order"]
        assert [d.label for d in h5["cell_center"].dims] == ["cell", "xyz"]
        assert list(h5["cell_center"].dims[1].keys()) == ["xyz"]
        assert [v.decode() for v in h5["xyz"][()]] == ["x", "y", "z"]
        for name in ("absorbed", "truncated", "degenerate", "paths", "max_bounces_seen"):
            assert list(h5[name].dims[0].keys()) == ["theta_i", "phi_i"]
        for name in ("cell_solid_angle", "cell_projected_solid_angle"):
            assert list(h5[name].dims[0].keys()) == ["cell"]
        for name in ("theta_i", "phi_i", "order", "cell", "xyz"):
            assert h5[name].is_scale
        np.testing.assert_array_equal(h5["cell"][()], np.arange(25))
        # The attached scale is the coordinate dataset itself.
        np.testing.assert_array_equal(h5["brdf"].dims[0]["theta_i"][()], h5["theta_i"][()])


def test_units_and_descriptions(written):
    expected_units = {
        "brdf": "1/sr", "brdf_stderr": "1/sr", "counts": "1", "albedo": "1",
        "theta_i": "rad", "phi_i": "rad", "order": "1", "cell": "1", "absorbed": "1",
        "truncated": "1", "degenerate": "1", "paths": "1", "max_bounces_seen": "1",
        "cell_center": "1", "cell_solid_angle": "sr", "cell_projected_solid_angle": "sr",
    }
    with h5py.File(written[0], "r") as h5:
        datasets = [n for n in h5 if isinstance(h5[n], h5py.Dataset)]
        assert set(datasets) == set(expected_units) | {"xyz"}
        for name in datasets:
            assert h5[name].attrs["description"].strip(), name
        for name, units in expected_units.items():
            assert h5[name].attrs["units"] == units, name
        assert h5["material"].attrs["description"]


def test_root_attributes(written, sensor):
    with h5py.File(written[0], "r") as h5:
        attrs = h5.attrs
        assert attrs["format"] == "vcavity-brdf-table"
        assert attrs["format_version"] == 1
        assert attrs["vcavity_version"] == vcavity.__version__
        assert attrs["sensor_partition"] == "shirley-chiu-concentric"
        assert attrs["sensor_resolution"] == 5 and attrs["n_cells"] == 25
        assert attrs["seed"] == 7 and attrs["block_size"] == 4096
        assert attrs["max_bounces"] == 1000
        assert json.loads(attrs["config"]) == CONFIG
        assert attrs["created_utc"].endswith("Z")
        assert h5["material"].attrs["distribution"] == "beckmann"
        assert "exponent" not in h5["material"].attrs  # None = does not apply


def test_write_replaces_existing_file(written, sensor):
    path, _ = written
    other = consistent_run(99, sensor, n_incidence=2)
    write(path, other, sensor, seed=123)
    table = open_table(path)
    assert table.seed == 123
    np.testing.assert_array_equal(table.counts, other["counts"])
    assert os.listdir(path.parent) == [path.name]


def test_failed_write_leaves_existing_file_untouched(written, sensor, monkeypatch):
    path, _ = written
    before = path.read_bytes()

    def fail_midway(h5, material):
        raise RuntimeError("disk on fire")

    # _write_material runs after all datasets are in the temporary file.
    monkeypatch.setattr(table_module, "_write_material", fail_midway)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write(path, consistent_run(3, sensor), sensor)
    assert path.read_bytes() == before
    assert os.listdir(path.parent) == [path.name]  # no temporary file left behind
    with pytest.raises(RuntimeError):
        write(path.parent / "new.h5", consistent_run(3, sensor), sensor)
    assert os.listdir(path.parent) == [path.name]


def test_inconsistent_input_is_rejected_before_writing(tmp_path, sensor):
    run = consistent_run(11, sensor)
    leaky = dict(run, absorbed_paths=run["absorbed_paths"] - 1)  # one path unaccounted for
    with pytest.raises(ValueError, match="!= paths"):
        write(tmp_path / "t.h5", leaky, sensor)
    surplus = dict(run, degenerate_paths=run["degenerate_paths"] + 1)
    with pytest.raises(ValueError, match="exceed paths"):
        write(tmp_path / "t.h5", surplus, sensor)
    with pytest.raises(ValueError, match="counts must have shape"):
        write(tmp_path / "t.h5", dict(run, counts=run["counts"][:, :, :-1]), sensor)
    with pytest.raises(ValueError, match="order must be"):
        write(tmp_path / "t.h5", dict(run, order=[0, 2, 3, 4]), sensor)
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
        h5.attrs["format_version"] = 2
    message = _single_line_error(path, "unsupported format_version")
    assert message == f"unsupported format_version 2 in {path} (this vcavity reads 1)"


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


def test_documentation_snippets_run(written, sensor):
    """The ```python blocks of docs/hdf5-format.md run, in order, against a real table."""
    path, _ = written
    text = DOCS.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 3
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
                                  sensor.cell_index(directions))
