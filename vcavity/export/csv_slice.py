"""``--format csv``: the in-plane slice of one incident direction as a CSV file.

The slice is the one ``vcavity plot --kind slice`` draws (:mod:`vcavity.sensor.plane`):
the great circle through the pole and the incident azimuth, parametrised by the signed
angle ``theta_o_deg`` in ``[-90, 90]``: ``< 0`` back toward the light (``phi_o = phi_i``),
``>= 0`` on the specular side (``phi_o = phi_i + 180``; the mirror direction is
``theta_o_deg = theta_i``). A table holds cell averages, so the slice is a step function:
one row per stretch of the circle inside one sensor cell, in increasing ``theta_o_deg``
(the stretch's middle), with that cell's ``brdf`` and ``brdf_stderr``. Where the circle
runs along a cell border (e.g. ``phi_i = 0`` on a sensor of even resolution), the stretch
gives two rows with the same angles, one per side; the plot draws their mean.

Layout: ``#`` comment lines (vcavity version, source table, material, incident direction,
order, units, conventions; the first says how many lines precede the data), the header
row ``theta_o_deg,phi_o_deg,cell,brdf,brdf_stderr``, then the rows. Readable by
``numpy.loadtxt(FILE, delimiter=",", skiprows=S)`` (S as the first line states),
``pandas.read_csv(FILE, comment="#")`` and the ``csv`` module (after dropping the lines
that start with ``#``).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vcavity.export import ExportRefused, ExportRequest, header_text, order_data

NAME = "csv"
SOURCE = "table"
SUFFIX = ".csv"
SUMMARY = "in-plane slice (plane of incidence) of one incident direction, CSV"

COLUMNS = ("theta_o_deg", "phi_o_deg", "cell", "brdf", "brdf_stderr")
#: --theta-i matches a tabulated theta_i_deg this close (deg), as `vcavity plot --theta-i`.
THETA_I_MATCH_DEG = 1e-6
#: Angles are written rounded to this many decimals (deg): the slice's cell borders are
#: located to ~5e-11 deg (sensor.plane), finer digits are bisection noise.
ANGLE_DECIMALS = 9


@dataclass(frozen=True)
class CsvSlice:
    """What :func:`write` writes.

    Attributes
    ----------
    comments : tuple of str
        The comment lines, without the leading ``"# "``.
    theta_o_deg, phi_o_deg : ndarray (n,)
        Signed angle along the plane (middle of the stretch) and the azimuth of that
        direction in ``(-180, 180]``, degrees.
    cell : ndarray of int64 (n,)
    brdf, brdf_stderr : ndarray (n,)
        The table's values of ``cell``, 1/sr.
    """

    comments: tuple
    theta_o_deg: np.ndarray
    phi_o_deg: np.ndarray
    cell: np.ndarray
    brdf: np.ndarray
    brdf_stderr: np.ndarray


def _listed(values) -> str:
    return ", ".join(f"{v:g}" for v in values)


def incidence_index(table, theta_i_text) -> int:
    """The incidence row of the slice: ``--theta-i`` matched as ``vcavity plot`` does.

    Parameters
    ----------
    table : vcavity.io.table.Table
    theta_i_text : str or None
        The incident polar angle in degrees as in the run config; None: the table's
        only incident direction.

    Raises
    ------
    ExportRefused
        Not a number, not a tabulated theta_i (the message lists them), none given for a
        table of several, or several directions (azimuths) at that theta_i.
    """
    shown = str(table.path)
    theta = np.asarray(table.theta_i_deg, dtype=np.float64)
    phi = np.asarray(table.phi_i_deg, dtype=np.float64)
    if theta_i_text is None:
        if theta.size == 1:
            return 0
        if not np.allclose(theta, theta[0], rtol=0.0, atol=THETA_I_MATCH_DEG):
            raise ExportRefused(f"table {shown!r}: has several incident directions (theta_i_deg: "
                                f"{_listed(theta)}) and a CSV holds one slice; choose one with "
                                "--theta-i DEG")
        asked, hits = f"table {shown!r}", np.arange(theta.size)
    else:
        try:
            value = float(theta_i_text)
        except ValueError:
            raise ExportRefused(f"--theta-i = {theta_i_text!r}: expected an angle in degrees") from None
        hits = np.flatnonzero(np.isclose(theta, value, rtol=0.0, atol=THETA_I_MATCH_DEG))
        if hits.size == 0:
            raise ExportRefused(f"--theta-i = {value:g}: not an incident direction of table "
                                f"{shown!r} (theta_i_deg: {_listed(theta)})")
        asked = f"--theta-i = {value:g}: table {shown!r}"
    if hits.size > 1:
        raise ExportRefused(f"{asked} has {hits.size} incident directions at theta_i_deg = "
                            f"{theta[hits[0]]:g} (phi_i_deg: {_listed(phi[hits])}) and a CSV holds "
                            "one slice, with no option to pick an azimuth; `vcavity plot --kind "
                            "slice` draws them all")
    return int(hits[0])


def _wrap_deg(angle):
    """Degrees into ``(-180, 180]``, the convention of the table's ``phi_o``."""
    return 180.0 - np.mod(180.0 - np.asarray(angle, dtype=np.float64), 360.0)


def _comments(table, index: int, request: ExportRequest, n_lines_before_data: int) -> tuple:
    from vcavity._version import __version__

    order = request.order
    order_text = ("0 (f_inf: all bounce orders)" if order == 0
                  else f"{order} (light that left after exactly {order} bounces)")
    return (
        f"vcavity {__version__}: in-plane slice of a BRDF table (vcavity export --format csv); "
        f"{n_lines_before_data} lines precede the data: "
        f"numpy.loadtxt(FILE, delimiter=',', skiprows={n_lines_before_data})",
        f"source table: {Path(table.path).resolve()} (written by vcavity {table.vcavity_version})",
        f"material: {json.dumps(table.material, sort_keys=True)}",
        f"incident direction (toward the light): theta_i_deg = {float(table.theta_i_deg[index]):g}, "
        f"phi_i_deg = {float(table.phi_i_deg[index]):g}, paths = {int(table.paths[index])}",
        f"order = {order_text}",
        "units: theta_o_deg and phi_o_deg in degrees; brdf and brdf_stderr in 1/sr (the cell's "
        "cosine-weighted average of the BRDF and its standard error)",
        "theta_o_deg: signed angle along the plane of incidence, the middle of the row's stretch "
        "inside its cell: < 0 toward the light (phi_o = phi_i), >= 0 the specular side "
        "(phi_o = phi_i + 180)",
        f"cell: sensor cell index iy * N + ix (N = {table.sensor.resolution}); where the plane runs "
        "along a cell border a stretch gives two rows, one per side",
    )


def prepare(table, request: ExportRequest) -> CsvSlice:
    """Check the request and collect the rows of the slice.

    Parameters
    ----------
    table : vcavity.io.table.Table
    request : ExportRequest
        ``order`` and ``theta_i_deg`` (:func:`incidence_index`).

    Returns
    -------
    CsvSlice

    Raises
    ------
    ExportRefused
        An order the table lacks, or an incident direction that names no single row.
    """
    from vcavity.sensor.plane import plane_segments

    brdf_of_order, order_index = order_data(table, request)
    index = incidence_index(table, request.theta_i_deg)
    segments = plane_segments(table.sensor.resolution, float(table.phi_i[index]))
    middles = np.round(segments.centers, ANGLE_DECIMALS) + 0.0  # + 0.0: no "-0.0"
    pairs = segments.cells
    two_sided = pairs[:, 0] != pairs[:, 1]
    # one row per stretch, two (first side, then the other) where it runs along a border
    stretch = np.repeat(np.arange(pairs.shape[0]), np.where(two_sided, 2, 1))
    side = np.concatenate([[0, 1] if both else [0] for both in two_sided]).astype(np.int64)
    cell = pairs[stretch, side]
    theta_o = middles[stretch]
    phi_i_deg = float(table.phi_i_deg[index])
    phi_o = np.round(_wrap_deg(np.where(theta_o < 0.0, phi_i_deg, phi_i_deg + 180.0)),
                     ANGLE_DECIMALS) + 0.0
    stderr = np.asarray(table.brdf_stderr[index, order_index], dtype=np.float64)
    n_lines = len(_comments(table, index, request, 0)) + 1  # the comments and the header row
    return CsvSlice(comments=_comments(table, index, request, n_lines), theta_o_deg=theta_o,
                    phi_o_deg=phi_o, cell=cell.astype(np.int64),
                    brdf=np.asarray(brdf_of_order[index], dtype=np.float64)[cell],
                    brdf_stderr=stderr[cell])


def write(prepared: CsvSlice, path) -> None:
    """Write the comment lines, the header row and the rows (full float precision).

    Parameters
    ----------
    prepared : CsvSlice
    path : str or os.PathLike
    """
    with open(path, "w", newline="", encoding="utf-8") as out:
        for line in prepared.comments:
            out.write(f"# {header_text(line)}\n")  # a file name holding a newline stays one line
        rows = csv.writer(out, lineterminator="\n")
        rows.writerow(COLUMNS)
        for theta_o, phi_o, cell, brdf, stderr in zip(prepared.theta_o_deg, prepared.phi_o_deg,
                                                      prepared.cell, prepared.brdf,
                                                      prepared.brdf_stderr):
            rows.writerow((repr(float(theta_o)), repr(float(phi_o)), int(cell), repr(float(brdf)),
                           repr(float(stderr))))
