"""The HDF5 layout of a format-2 table, read with plain h5py (docs/hdf5-format.md).

The expected layout is written out here from the documentation, independently of
vcavity.io.schema, so a change of the writer that the documentation does not describe
fails.
"""

import json

import h5py
import numpy as np

import vcavity

INCIDENCE_COORDINATES = {"theta_i", "phi_i", "theta_i_deg", "phi_i_deg"}
CELL_COORDINATES = {"theta_o", "phi_o"}
# dataset -> (axes, units); None = no units attribute
LAYOUT = {
    "incidence": (("incidence",), "1"),
    "order": (("order",), "1"),
    "cell": (("cell",), "1"),
    "xyz": (("xyz",), None),
    "theta_i": (("incidence",), "rad"),
    "phi_i": (("incidence",), "rad"),
    "theta_i_deg": (("incidence",), "degree"),
    "phi_i_deg": (("incidence",), "degree"),
    "theta_o": (("cell",), "rad"),
    "phi_o": (("cell",), "rad"),
    "brdf": (("incidence", "order", "cell"), "1/sr"),
    "brdf_stderr": (("incidence", "order", "cell"), "1/sr"),
    "counts": (("incidence", "order", "cell"), "1"),
    "albedo": (("incidence", "order"), "1"),
    "absorbed": (("incidence",), "1"),
    "truncated": (("incidence",), "1"),
    "degenerate": (("incidence",), "1"),
    "paths": (("incidence",), "1"),
    "max_bounces_seen": (("incidence",), "1"),
    "cell_center": (("cell", "xyz"), "1"),
    "cell_solid_angle": (("cell",), "sr"),
    "cell_projected_solid_angle": (("cell",), "sr"),
    "order_source": (("order",), "1"),
    "unbinned_paths": (("incidence",), "1"),
    "folded": (("incidence",), "1"),
    "relative_error": (("incidence",), "1"),
    "target_reached": (("incidence",), "1"),
}
SCALES = ("incidence", "order", "cell", "xyz")


def test_every_axis_has_exactly_one_scale_named_like_it(written):
    path, run = written
    with h5py.File(path, "r") as h5:
        datasets = {name for name in h5 if isinstance(h5[name], h5py.Dataset)}
        assert datasets == set(LAYOUT)
        for name, (axes, _) in LAYOUT.items():
            dataset = h5[name]
            assert dataset.ndim == len(axes), name
            if name in SCALES:
                assert dataset.is_scale and h5py.h5ds.get_scale_name(dataset.id) == name.encode()
                continue
            assert not dataset.is_scale, name  # theta_i & co. are coordinates, not scales
            for position, axis in enumerate(axes):
                # netCDF readers name an axis after its scale: one scale, the axis itself
                assert list(dataset.dims[position].keys()) == [axis], (name, position)
                assert dataset.dims[position][0] == h5[axis]
            assert "DIMENSION_LABELS" not in dataset.attrs, name
        np.testing.assert_array_equal(h5["incidence"][()], np.arange(run["theta_i"].size))
        np.testing.assert_array_equal(h5["order"][()], run["order"])
        np.testing.assert_array_equal(h5["cell"][()], np.arange(25))
        assert h5["xyz"].dtype == np.dtype("S1") and h5["xyz"][()].tolist() == [b"x", b"y", b"z"]


def test_units_long_names_descriptions(written):
    with h5py.File(written[0], "r") as h5:
        for name, (_, units) in LAYOUT.items():
            attrs = h5[name].attrs
            assert attrs["description"].strip() and attrs["long_name"].strip(), name
            if units is None:
                assert "units" not in attrs, name
            else:
                assert attrs["units"] == units, name
        assert h5["material"].attrs["description"]


def test_coordinates_attribute_names_the_axis_angles(written):
    """CF: a data variable lists the auxiliary coordinates of its axes."""
    with h5py.File(written[0], "r") as h5:
        for name, (axes, _) in LAYOUT.items():
            is_coordinate = name in SCALES or name in INCIDENCE_COORDINATES | CELL_COORDINATES
            if is_coordinate:
                assert "coordinates" not in h5[name].attrs, name
                continue
            expected = (INCIDENCE_COORDINATES if "incidence" in axes else set()) | (
                CELL_COORDINATES if "cell" in axes else set())
            if not expected:  # e.g. order_source: its axis has no auxiliary coordinates
                assert "coordinates" not in h5[name].attrs, name
                continue
            assert set(h5[name].attrs["coordinates"].split()) == expected, name


def test_angle_coordinates(written, sensor):
    path, run = written
    with h5py.File(path, "r") as h5:
        np.testing.assert_array_equal(h5["theta_i"][()], run["theta_i"])
        np.testing.assert_array_equal(h5["theta_i_deg"][()], np.degrees(run["theta_i"]))
        np.testing.assert_array_equal(h5["phi_i_deg"][()], np.degrees(run["phi_i"]))
        x, y, z = h5["cell_center"][()].T
        np.testing.assert_allclose(h5["theta_o"][()], np.arccos(np.clip(z, -1, 1)), atol=1e-7)
        np.testing.assert_allclose(np.cos(h5["phi_o"][()]) * np.hypot(x, y), x, atol=1e-15)
        np.testing.assert_allclose(np.sin(h5["phi_o"][()]) * np.hypot(x, y), y, atol=1e-15)


def test_three_dimensional_datasets_are_compressed_per_incidence(written):
    path, run = written
    n_orders = run["order"].size
    with h5py.File(path, "r") as h5:
        for name in ("brdf", "brdf_stderr", "counts"):
            dataset = h5[name]
            assert dataset.chunks == (1, n_orders, 25), name
            assert dataset.compression == "gzip" and dataset.compression_opts == 4, name
            assert dataset.shuffle, name


def test_root_attributes(written, config):
    with h5py.File(written[0], "r") as h5:
        attrs = h5.attrs
        assert attrs["format"] == "vcavity-brdf-table"
        assert attrs["format_version"] == 3
        assert attrs["vcavity_version"] == vcavity.__version__
        assert attrs["sensor_partition"] == "shirley-chiu-concentric"
        assert attrs["sensor_resolution"] == 5 and attrs["n_cells"] == 25
        assert attrs["seed"] == 7 and attrs["block_size"] == 4096
        assert attrs["max_bounces"] == 1000
        assert json.loads(attrs["config"]) == config
        assert attrs["created_utc"].endswith("Z")
        assert attrs["compute_time_s"] == 1.5 and attrs["compile_time_s"] == 0.25
        assert attrs["description"] and attrs["conventions"]
        assert h5["material"].attrs["distribution"] == "beckmann"
        assert "exponent" not in h5["material"].attrs  # None = does not apply
