"""``--format merl``: a table as a MERL isotropic BRDF file (Matusik et al. 2003, ``.binary``).

The layout is the one the MERL database's ``BRDFRead.cpp`` reads: three little-endian
int32 ``90, 90, 180`` (theta_h, theta_d, phi_d bins), then ``3 * 90 * 90 * 180``
little-endian float64, all red values, then all green, then all blue. Bin
``(i, j, k)`` is at ``k + 180 * (j + 90 * i)`` within a channel; the reader multiplies a
channel by its scale (:data:`CHANNEL_SCALES`), so ``f / scale`` is stored.

Bins, as the reader looks them up (phi_h is ignored: the file is isotropic):

- theta_h in ``[0, pi/2)``, non-linear: ``i = floor(sqrt(theta_h / (pi/2)) * 90)``;
- theta_d in ``[0, pi/2)``, linear: ``j = floor(theta_d / (pi/2) * 90)``;
- phi_d in ``[0, pi)``: ``k = floor(phi_d / pi * 180)`` after ``phi_d < 0 -> phi_d + pi``.
  Swapping ``wi`` and ``wo`` turns phi_d into phi_d + pi, so one bin serves both
  directions of a reciprocal pair.

Each bin holds the table at its centre (``i + 1/2`` in the square-root coordinate,
``j + 1/2``, ``k + 1/2``), converted to ``(wi, wo)`` by the half/difference rotation of
Rusinkiewicz (1998) at phi_h = 0 and evaluated with the table API
(``table.eval``, docs/table-api.md), averaged over the two directions of the pair:
``(f(wi, wo) + f(wo, wi)) / 2``. A simulated table is reciprocal only up to its noise and
its interpolation in theta_i, and readers disagree on which vector they call "in"; the
mean is the one value that does not depend on it. Bins whose centre has ``wi`` or ``wo``
at or below the horizon hold ``-1`` in every channel (before scaling), the mark of the
public MERL files for entries without data; readers treat negative values as invalid.

Plain NumPy: no Numba.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vcavity.export import ExportRefused, ExportRequest, order_data

NAME = "merl"
SOURCE = "table"
SUFFIX = ".binary"
SUMMARY = "MERL isotropic BRDF file (90 x 90 x 180 half/difference bins, grey RGB)"

THETA_H_BINS, THETA_D_BINS, PHI_D_BINS = 90, 90, 180
#: The reader's factors per channel (red, green, blue): the file stores f / scale.
CHANNEL_SCALES = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
#: Stored (before scaling) where a bin centre lies below the horizon, as the MERL files do.
INVALID = -1.0
#: theta_h bins evaluated per call of table.eval: 10 x 90 x 180 = 162 000 direction pairs
#: (a few tens of MB of temporaries instead of ~1 GB for all 1.46 M at once).
THETA_H_BINS_PER_CHUNK = 10
#: Tabulated theta_i closer than this (deg) count as one incident direction.
THETA_I_MATCH_DEG = 1e-6


@dataclass(frozen=True)
class MerlBins:
    """The grey BRDF of every bin, what :func:`write` stores.

    Attributes
    ----------
    brdf : ndarray (90, 90, 180)
        ``f`` in 1/sr at the bin centres, indexed ``[theta_h, theta_d, phi_d]``;
        :data:`INVALID` where the centre lies below the horizon.
    valid : ndarray of bool (90, 90, 180)
        Whether the centre has ``wi`` and ``wo`` above the horizon.
    """

    brdf: np.ndarray
    valid: np.ndarray


def bin_centres():
    """Angles (rad) of the bin centres: theta_h (90,), theta_d (90,), phi_d (180,)."""
    theta_h = (0.5 * np.pi) * ((np.arange(THETA_H_BINS) + 0.5) / THETA_H_BINS) ** 2
    theta_d = (0.5 * np.pi) * (np.arange(THETA_D_BINS) + 0.5) / THETA_D_BINS
    phi_d = np.pi * (np.arange(PHI_D_BINS) + 0.5) / PHI_D_BINS
    return theta_h, theta_d, phi_d


def half_diff_to_directions(theta_h, theta_d, phi_d):
    """``(wi, wo)`` of half/difference angles at phi_h = 0 (Rusinkiewicz 1998), broadcast.

    The difference vector ``d`` (the incident direction in the frame of the half vector)
    is rotated about ``+y`` by theta_h; ``wo`` is ``d`` mirrored about the half vector,
    rotated the same way. The inverse of the reader's ``std_coords_to_half_diff_coords``.

    Returns
    -------
    wi, wo : ndarray (..., 3)
    """
    theta_h, theta_d, phi_d = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                                    for a in (theta_h, theta_d, phi_d)))
    sin_d = np.sin(theta_d)
    dx, dy, dz = sin_d * np.cos(phi_d), sin_d * np.sin(phi_d), np.cos(theta_d)
    cos_h, sin_h = np.cos(theta_h), np.sin(theta_h)
    # rotation about +y by theta_h: (x, y, z) -> (x cos + z sin, y, z cos - x sin)
    wi = np.stack([dx * cos_h + dz * sin_h, dy, dz * cos_h - dx * sin_h], axis=-1)
    wo = np.stack([-dx * cos_h + dz * sin_h, -dy, dz * cos_h + dx * sin_h], axis=-1)
    return wi, wo


def _check(table, request: ExportRequest) -> None:
    """Refuse what a MERL file cannot represent (ExportRefused, one line)."""
    from vcavity.brdf.table_brdf import material_is_isotropic

    shown = str(table.path)
    if not material_is_isotropic(table.material):
        raise ExportRefused(
            f"table {shown!r}: MERL files are isotropic (one value per theta_h, theta_d, phi_d) "
            f"and this material is anisotropic (alpha_x = {table.material.get('alpha_x')}, "
            f"alpha_y = {table.material.get('alpha_y')}); export a table of an isotropic "
            "material (alpha_x = alpha_y)")
    order_data(table, request)
    theta = np.asarray(table.theta_i_deg, dtype=np.float64)
    distinct = np.unique(np.round(theta / THETA_I_MATCH_DEG) * THETA_I_MATCH_DEG)
    if distinct.size < 2:
        raise ExportRefused(
            f"table {shown!r}: has one incident polar angle (theta_i_deg = {distinct[0]:g}) and "
            "a MERL file covers every incident direction; simulate several, e.g. "
            "theta_i_deg = [0, 10, 20, 30, 40, 50, 60, 70, 80, 85]")


def prepare(table, request: ExportRequest) -> MerlBins:
    """Check the table and evaluate it at every bin centre.

    Parameters
    ----------
    table : vcavity.io.table.Table
    request : ExportRequest
        ``order``: the bounce order exported.

    Returns
    -------
    MerlBins

    Raises
    ------
    ExportRefused
        An anisotropic material, an order the table lacks, or fewer than two distinct
        tabulated theta_i.
    """
    _check(table, request)
    theta_h, theta_d, phi_d = bin_centres()
    shape = (THETA_H_BINS, THETA_D_BINS, PHI_D_BINS)
    brdf, valid = np.full(shape, INVALID), np.zeros(shape, dtype=bool)
    for start in range(0, THETA_H_BINS, THETA_H_BINS_PER_CHUNK):
        rows = slice(start, start + THETA_H_BINS_PER_CHUNK)
        wi, wo = half_diff_to_directions(theta_h[rows, None, None], theta_d[None, :, None],
                                         phi_d[None, None, :])
        up = (wi[..., 2] > 0.0) & (wo[..., 2] > 0.0)
        forward = table.eval(wi[up], wo[up], order=request.order)
        backward = table.eval(wo[up], wi[up], order=request.order)
        chunk = brdf[rows]  # a view: filled in place
        chunk[up] = 0.5 * (forward + backward)
        valid[rows] = up
    return MerlBins(brdf=brdf, valid=valid)


def write(prepared: MerlBins, path) -> None:
    """Write the MERL file: int32 dims, then red, green, blue float64 (little-endian).

    Parameters
    ----------
    prepared : MerlBins
    path : str or os.PathLike
    """
    with open(path, "wb") as out:
        out.write(np.array([THETA_H_BINS, THETA_D_BINS, PHI_D_BINS], dtype="<i4").tobytes())
        for scale in CHANNEL_SCALES:
            out.write(np.where(prepared.valid, prepared.brdf / scale, INVALID).astype("<f8").tobytes())
