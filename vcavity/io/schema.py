"""Layout of vcavity BRDF tables: dataset names, axes, units, descriptions (docs/hdf5-format.md).

Format version 3 (as version 2 before it) is an HDF5 file that netCDF-4 readers (netCDF-C, netCDF4-python,
h5netcdf, xarray) read as a netCDF dataset without options:

- every axis (``incidence``, ``order``, ``cell``, ``xyz``) has exactly one dimension-scale
  dataset of the same name, which every dataset using that axis has attached;
- the angles of each axis (``theta_i``, ``phi_i``, ``theta_i_deg``, ``phi_i_deg`` on
  ``incidence``; ``theta_o``, ``phi_o`` on ``cell``) are ordinary datasets on it, named as
  auxiliary coordinates by the CF ``coordinates`` attribute of every data variable.

Format version 3 adds what the estimators need (``unbinned_paths``, ``order_source``,
``folded``, ``relative_error``, ``target_reached`` and the root attributes ``estimator``,
``target_error``): ``brdf`` is no longer always ``counts / (paths Ω⊥)`` (exact-f1 adds the
analytic f1; folded directions average mirror cells). Version 2 tables are read with the
analog, unfolded values of these.

Format version 1 attached two scales (``theta_i`` and ``phi_i``) to the incidence axis and
had no degree or outgoing angles; it is still read (:data:`V1_DATASETS`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

FORMAT_NAME = "vcavity-brdf-table"
FORMAT_VERSION = 3
#: Versions open_table reads.
READABLE_VERSIONS = (1, 2, 3)

#: Axis -> its dimension-scale dataset (same name) comes first in the file, in this order.
AXES = ("incidence", "order", "cell", "xyz")

#: Axis -> auxiliary coordinates on it (CF ``coordinates`` attribute of data variables).
AUXILIARY_COORDINATES = {
    "incidence": ("theta_i", "phi_i", "theta_i_deg", "phi_i_deg"),
    "cell": ("theta_o", "phi_o"),
}

# Dataset -> (axes, units, long_name, description), in the order datasets are written:
# scales, auxiliary coordinates, data variables. units None = not a physical quantity.
DATASETS = {
    "incidence": (("incidence",), "1", "incident direction index",
                  "Position of the incident direction on the incidence axis, 0 .. n_incidence-1"),
    "order": (("order",), "1", "bounce order",
              "Bounce order: 0 = all orders together (f_inf), k >= 1 = paths that left after "
              "exactly k bounces"),
    "cell": (("cell",), "1", "sensor cell index",
             "Sensor cell index, as returned by the sensor's cell_index"),
    "xyz": (("xyz",), None, "Cartesian component",
            "Cartesian component of a direction (macro normal = z)"),
    "theta_i": (("incidence",), "rad", "incident polar angle",
                "Polar angle of the incident direction i, from +z"),
    "phi_i": (("incidence",), "rad", "incident azimuth",
              "Azimuth of the incident direction i, from +x toward +y"),
    "theta_i_deg": (("incidence",), "degree", "incident polar angle",
                    "Polar angle of the incident direction i, from +z, in degrees as given "
                    "in the run configuration"),
    "phi_i_deg": (("incidence",), "degree", "incident azimuth",
                  "Azimuth of the incident direction i, from +x toward +y, in degrees as "
                  "given in the run configuration"),
    "theta_o": (("cell",), "rad", "outgoing polar angle of the cell centre",
                "Polar angle from +z of the direction at the centre of each sensor cell"),
    "phi_o": (("cell",), "rad", "outgoing azimuth of the cell centre",
              "Azimuth from +x toward +y of the direction at the centre of each sensor cell, "
              "in (-pi, pi] (0 at the pole)"),
    "brdf": (("incidence", "order", "cell"), "1/sr", "cell-averaged BRDF",
             "Cell-averaged cosine-weighted BRDF (1/Ω⊥_c) ∫_c f_k(i,o) cos(theta_o) dω_o: "
             "analog estimator counts / (paths * cell_projected_solid_angle); exact-f1 adds "
             "the analytic f1 (order_source); folded directions (folded = 1) hold the mean "
             "of a cell and its mirror cell about the plane of incidence"),
    "brdf_stderr": (("incidence", "order", "cell"), "1/sr", "standard error of brdf",
                    "Standard error of brdf: binomial sqrt(n (1 - n/paths)) / (paths * Ω⊥) "
                    "of the cell's (folded: the cell pair's) simulated count, with the "
                    "analytic f1's quadrature error added in quadrature"),
    "counts": (("incidence", "order", "cell"), "1", "path count",
               "Number of paths of this order that exited through this cell (raw, never "
               "folded; exact-f1: first-order exits are not binned, see unbinned_paths)"),
    "order_source": (("order",), "1", "how each order was obtained",
                     "0 = simulated, 1 = analytic (the exact single-bounce model of the "
                     "microsurface, estimator exact-f1), 2 = analytic f1 plus simulated orders >= 2"),
    "albedo": (("incidence", "order"), "1", "albedo per order",
               "Fraction of paths leaving with this order: sum over cells of brdf * "
               "cell_projected_solid_angle"),
    "absorbed": (("incidence",), "1", "absorbed fraction",
                 "Fraction of paths absorbed inside a facet body"),
    "truncated": (("incidence",), "1", "truncated fraction",
                  "Fraction of paths stopped at the bounce cap max_bounces (their energy is "
                  "in no cell)"),
    "degenerate": (("incidence",), "1", "degenerate fraction",
                   "Fraction of paths the walk could not trace (numerically degenerate geometry)"),
    "paths": (("incidence",), "1", "paths simulated",
              "Number of paths simulated for this incident direction"),
    "unbinned_paths": (("incidence",), "1", "first-order exits not binned",
                       "Paths that left after one bounce, counted but not binned because "
                       "f1 is analytic (estimator exact-f1); 0 otherwise"),
    "folded": (("incidence",), "1", "mirror-symmetry fold applied",
               "1 if brdf of this direction averages each cell with its mirror cell about "
               "the plane of incidence, else 0"),
    "relative_error": (("incidence",), "1", "relative standard error of f_inf",
                       "Energy-weighted mean relative standard error of f_inf over the cells, "
                       "sum(brdf_stderr * Ω⊥) / sum(brdf * Ω⊥) (NaN without f_inf)"),
    "target_reached": (("incidence",), "1", "target error reached",
                       "Target-error runs: 1 if relative_error reached target_error, 0 if "
                       "the path cap stopped the direction first; -1 without a target"),
    "max_bounces_seen": (("incidence",), "1", "largest bounce count",
                         "Largest number of bounces made by any path of this incident direction"),
    "cell_center": (("cell", "xyz"), "1", "cell centre direction",
                    "Unit direction at the centre of each sensor cell"),
    "cell_solid_angle": (("cell",), "sr", "cell solid angle", "Solid angle of each sensor cell"),
    "cell_projected_solid_angle": (("cell",), "sr", "cell projected solid angle",
                                   "Projected solid angle of each sensor cell: integral of "
                                   "cos(theta_o) over the cell"),
}

#: Datasets of a format-1 table.
V1_DATASETS = ("theta_i", "phi_i", "order", "cell", "xyz", "brdf", "brdf_stderr", "counts",
               "albedo", "absorbed", "truncated", "degenerate", "paths", "max_bounces_seen",
               "cell_center", "cell_solid_angle", "cell_projected_solid_angle")
#: Datasets a format-2 table adds.
V2_ADDED_DATASETS = ("incidence", "theta_i_deg", "phi_i_deg", "theta_o", "phi_o")
#: Datasets a format-3 table adds.
V3_ADDED_DATASETS = ("order_source", "unbinned_paths", "folded", "relative_error", "target_reached")
#: Flag attributes (CF flag_values / flag_meanings) of the int8 flag datasets.
FLAGS = {
    "order_source": ((0, 1, 2), "simulated analytic analytic_plus_simulated"),
    "folded": ((0, 1), "unfolded folded"),
    "target_reached": ((-1, 0, 1), "no_target not_reached reached"),
}

REQUIRED_ROOT_ATTRS = ("vcavity_version", "sensor_partition", "sensor_resolution", "n_cells",
                       "seed", "block_size", "max_bounces", "config")
#: Root attributes that become their own Table fields (everything else goes to Table.attrs).
ROOT_ATTRS_AS_FIELDS = ("format_version", "vcavity_version", "seed", "config")

CONVENTIONS = (
    "Macrosurface normal +z; all directions point away from the surface (incident "
    "direction i toward the light, outgoing o toward the viewer); theta measured from +z, "
    "phi measured from +x toward +y; angles in radians (theta_i_deg, phi_i_deg: degrees), "
    "solid angles in sr, BRDF in 1/sr."
)
ROOT_DESCRIPTION = (
    "Monte-Carlo BRDF of a microfacet V-cavity surface, per incident direction and "
    "bounce order, averaged over the cells of an equal-solid-angle hemispherical sensor: "
    "brdf[i, k, c] = counts[i, k, c] / (paths[i] * cell_projected_solid_angle[c]). "
    "Layout: docs/hdf5-format.md of vcavity."
)
MATERIAL_DESCRIPTION = (
    "Material of the microsurface: microfacet distribution and its parameters, facet "
    "model, diffuse albedo kd and relative index of refraction eta (docs/hdf5-format.md)"
)
#: Compression of the 3-D datasets, stored in chunks of one incident direction.
GZIP_LEVEL = 4


def order_name(k: int) -> str:
    """The name of a bounce order as tables, reports and plots spell it.

    Parameters
    ----------
    k : int
        A value of the ``order`` axis: 1, 2, ... or 0 for all orders.

    Returns
    -------
    str
        ``"f_inf"`` for order 0, ``"f<k>"`` otherwise (the names ``vcavity info`` prints).
    """
    return "f_inf" if int(k) == 0 else f"f{int(k)}"


def orders_text(orders) -> str:
    """The orders of an ``order`` axis as ``--order`` spells them, e.g. ``"1, 2, 0 (f_inf)"``.

    Parameters
    ----------
    orders : iterable of int
        Values of the ``order`` axis (0 for all orders).

    Returns
    -------
    str
    """
    return ", ".join("0 (f_inf)" if int(k) == 0 else str(int(k)) for k in orders)


def is_scale(name: str) -> bool:
    """Whether a dataset is the dimension scale of an axis.

    Parameters
    ----------
    name : str
        Dataset name.

    Returns
    -------
    bool
        True for ``incidence``, ``order``, ``cell`` and ``xyz``.
    """
    return name in AXES


def coordinates_attribute(name: str) -> str | None:
    """The CF ``coordinates`` attribute of a dataset: its axes' auxiliary coordinates.

    Parameters
    ----------
    name : str
        A dataset of :data:`DATASETS`.

    Returns
    -------
    str or None
        Space-separated names, e.g. ``"theta_i phi_i theta_i_deg phi_i_deg"`` for a
        dataset on the incidence axis; None for scales and auxiliary coordinates.
    """
    auxiliary = {c for names in AUXILIARY_COORDINATES.values() for c in names}
    if is_scale(name) or name in auxiliary:
        return None
    axes = DATASETS[name][0]
    names = [c for axis in axes for c in AUXILIARY_COORDINATES.get(axis, ())]
    return " ".join(names) or None


#: Dtype of each dataset of a format-3 table as the writer stores it (the others float64).
DTYPES = {"incidence": "int64", "order": "int64", "cell": "int64", "xyz": "S1", "counts": "int64",
          "paths": "int64", "max_bounces_seen": "int64", "unbinned_paths": "int64", "order_source": "int8",
          "folded": "int8", "target_reached": "int8"}


@dataclass(frozen=True)
class TableValue:
    """One table as :func:`vcavity.io.writer.write_table` stores it, under the schema's names.

    An estimator makes it (:func:`vcavity.estimators.tabulate.tabulate`); the writer checks
    it as a reader would and writes it, computing nothing.

    Attributes
    ----------
    datasets : mapping of str to ndarray
        Every dataset of :data:`DATASETS`, with the dtype of :data:`DTYPES` (float64 else).
    material : mapping of str to scalar
        The ``/material`` attributes (``Material.to_dict()``; None values are omitted).
    attrs : mapping of str to scalar
        The root attributes a run gives (docs/hdf5-format.md), in the order written; the
        writer adds the format's own (``format``, ``format_version``, ``description``,
        ``conventions``, ``vcavity_version``, ``created_utc``) before them. ``config`` is
        a dict, stored as JSON.
    """

    datasets: Mapping[str, Any]
    material: Mapping[str, Any] = field(default_factory=dict)
    attrs: Mapping[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str):
        """The dataset ``name``."""
        return self.datasets[name]

