"""A format-2 table read as netCDF-4: xarray with both engines and netCDF4-python.

No reader gets options or custom code: the table must open as a netCDF dataset with
named dimensions, coordinates and units as it is. Values are compared with the Table
that vcavity.open_table reads from the same file.
"""

import json

import h5py
import netCDF4
import numpy as np
import pytest
import xarray as xr

from vcavity.io.table import open_table

ENGINES = ("h5netcdf", "netcdf4")
THETA_DEG = [0.0, 60.0, 80.0]
PHI_DEG = [0.0, 30.0, -45.0]
# variable -> units, for every physical variable of the file
UNITS = {"incidence": "1", "order": "1", "cell": "1", "theta_i": "rad", "phi_i": "rad",
         "theta_i_deg": "degree", "phi_i_deg": "degree", "theta_o": "rad", "phi_o": "rad",
         "brdf": "1/sr", "brdf_stderr": "1/sr", "counts": "1", "albedo": "1", "absorbed": "1",
         "truncated": "1", "degenerate": "1", "paths": "1", "max_bounces_seen": "1",
         "cell_center": "1", "cell_solid_angle": "sr", "cell_projected_solid_angle": "sr"}
# HDF5 dimension-scale bookkeeping that netCDF readers hide by design
HDF5_INTERNAL = {"CLASS", "NAME", "REFERENCE_LIST", "DIMENSION_LIST"}


@pytest.fixture(scope="module")
def table_path(tmp_path_factory, sensor, consistent_run, write, material):
    """A table with the user's degrees, a boolean material entry and a uint64 seed."""
    run = consistent_run(77, sensor, n_incidence=3)
    run.update(theta_i=np.radians(THETA_DEG), phi_i=np.radians(PHI_DEG))
    path = tmp_path_factory.mktemp("netcdf") / "table.h5"
    write(path, run, sensor, theta_i_deg=THETA_DEG, phi_i_deg=PHI_DEG, seed=2**64 - 1,
          material=dict(material, tracked=True))
    return path


@pytest.fixture(scope="module")
def table(table_path):
    return open_table(table_path)


@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_dimensions_and_coordinates(table_path, engine):
    with xr.open_dataset(table_path, engine=engine) as ds:
        assert dict(ds.sizes) == {"incidence": 3, "order": 4, "cell": 25, "xyz": 3}
        assert ds.brdf.dims == ("incidence", "order", "cell")
        assert set(ds.brdf.coords) == {"incidence", "theta_i", "phi_i", "theta_i_deg",
                                       "phi_i_deg", "order", "cell", "theta_o", "phi_o"}
        assert set(ds.indexes) == {"incidence", "order", "cell", "xyz"}
        assert ds.albedo.dims == ("incidence", "order")
        assert set(ds.albedo.coords) == {"incidence", "theta_i", "phi_i", "theta_i_deg",
                                         "phi_i_deg", "order"}
        assert ds.cell_center.dims == ("cell", "xyz")
        assert ds.xyz.values.tolist() == [b"x", b"y", b"z"]
        for name, units in UNITS.items():
            assert ds[name].attrs["units"] == units, name
            assert "DIMENSION_LABELS" not in ds[name].attrs, name


@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_values_match_the_table(table_path, table, engine):
    with xr.open_dataset(table_path, engine=engine) as ds:
        for name in ("brdf", "brdf_stderr", "counts", "albedo", "paths", "absorbed", "theta_i",
                     "phi_i", "theta_i_deg", "phi_i_deg", "theta_o", "phi_o", "cell_center",
                     "cell_projected_solid_angle"):
            np.testing.assert_array_equal(ds[name].values, getattr(table, name), err_msg=name)
        assert ds.theta_i_deg.values.tolist() == THETA_DEG  # the user's numbers, exactly


@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_selection_idioms(table_path, table, engine):
    with xr.open_dataset(table_path, engine=engine) as ds:
        f2_at_60 = ds.brdf.swap_dims(incidence="theta_i_deg").sel(theta_i_deg=60, order=2)
        assert f2_at_60.dims == ("cell",)
        np.testing.assert_array_equal(f2_at_60.values, table.brdf[1, table.order_index(2)])
        assert float(f2_at_60.phi_i_deg) == 30.0
        nearest = ds.brdf.swap_dims(incidence="theta_i").sel(theta_i=np.radians(79.0),
                                                             method="nearest")
        np.testing.assert_array_equal(nearest.sel(order=1).values,
                                      table.brdf[2, table.order_index(1)])
        np.testing.assert_array_equal(ds.albedo.sel(order=0).values,
                                      table.albedo[:, table.order_index(0)])
        by_pair = ds.set_xindex(["theta_i_deg", "phi_i_deg"]).brdf.sel(
            theta_i_deg=80, phi_i_deg=-45, order=3)
        np.testing.assert_array_equal(by_pair.values, table.brdf[2, table.order_index(3)])


@pytest.mark.parametrize("engine", ENGINES)
def test_xarray_attributes_and_material_group(table_path, table, engine, material):
    with xr.open_dataset(table_path, engine=engine) as ds:
        attrs = ds.attrs
        assert attrs["format"] == "vcavity-brdf-table" and attrs["format_version"] == 3
        assert attrs["seed"] == 2**64 - 1
        assert json.loads(attrs["config"]) == table.config
        for name in ("vcavity_version", "created_utc", "sensor_partition", "block_size",
                     "max_bounces", "sensor_resolution", "n_cells", "compute_time_s"):
            assert attrs[name] == table.attrs.get(name, getattr(table, name, None)), name
    with xr.open_dataset(table_path, engine=engine, group="material") as group:
        expected = {k: v for k, v in material.items() if v is not None} | {"tracked": 1}
        assert {k: v for k, v in group.attrs.items() if k != "description"} == expected


def test_netcdf4_python_keeps_every_attribute(table_path, table):
    """netCDF-C drops attributes it cannot type (an HDF5 enum, e.g. h5py's bool): none here."""
    with h5py.File(table_path, "r") as h5, netCDF4.Dataset(table_path) as nc:
        assert set(nc.ncattrs()) == set(h5.attrs)
        assert nc.getncattr("seed") == 2**64 - 1
        assert set(nc.groups["material"].ncattrs()) == set(h5["material"].attrs)
        assert nc.groups["material"].getncattr("tracked") == 1
        for name, variable in nc.variables.items():
            assert set(variable.ncattrs()) == set(h5[name].attrs) - HDF5_INTERNAL, name
        assert {name: len(dim) for name, dim in nc.dimensions.items()} == {
            "incidence": 3, "order": 4, "cell": 25, "xyz": 3}
        assert nc["brdf"].dimensions == ("incidence", "order", "cell")
        assert nc["theta_i"].dimensions == ("incidence",)
        assert nc["brdf"].getncattr("coordinates").split() == [
            "theta_i", "phi_i", "theta_i_deg", "phi_i_deg", "theta_o", "phi_o"]
        np.testing.assert_array_equal(nc["brdf"][:], table.brdf)
        np.testing.assert_array_equal(nc["counts"][:], table.counts)
        np.testing.assert_array_equal(nc["theta_i_deg"][:], THETA_DEG)
