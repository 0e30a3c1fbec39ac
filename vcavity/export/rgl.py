"""RGL measured-BSDF export (``--format rgl``): the tensor file of Dupuy & Jakob 2018.

Mitsuba 3's ``measured`` plugin (and pbrt-v4's measured BxDF, Falcor) evaluate such a
file as (docs/exports.md, "RGL"; Mitsuba ``src/bsdfs/measured.cpp``)::

    f(wi, wo) cos(theta_o) = R(s) * ndf(u_m) / (4 sigma(u_wi)),   s = vndf^-1(u_m)

with ``m`` the half vector, ``u`` the unit-square coordinates of a direction
(:mod:`vcavity.export.rgl_grids`; the azimuth of ``m`` relative to ``phi_i`` for isotropic
files), ``ndf`` and ``sigma`` bilinear grids over ``u_m`` and ``u_wi``, ``vndf`` a
continuous marginal warp (:mod:`vcavity.export.marginal2d`) of the visible-normal density
``ndf(m) <wi.m>`` and ``R`` the colour grid over the warp's domain ``s`` (``rgb`` here,
``spectra`` in :mod:`vcavity.export.rgl_spectral`), interpolated bilinearly in ``s``.

What this module writes:

- ``ndf``: the V-cavity surface's own normal distribution ``D`` (the table's
  distribution, through the registry), mixed with a cosine floor,
  ``ndf = (1 - w) D + w / pi`` (both integrate to 1 against ``cos theta_m``). ``w`` is
  :data:`BODY_FLOOR` for facets with a Lambertian body (their diffuse light leaves where
  ``D(h)`` of a sharp lobe is ~0 and must stay reachable by sampling) and
  :data:`MIN_FLOOR` otherwise (it only keeps ``R`` finite where ``D`` underflows);
- ``sigma``: the projected area ``∫ ndf(m) max(0, wi.m) dω_m``;
- ``vndf``: ``ndf(m) max(0, wi.m)`` times the Jacobian of the unit-square map, per
  incident direction of the file (the warp normalises it);
- ``rgb`` (grey: three equal channels) and ``luminance``: at each node ``s`` of the
  colour grid, ``R(s) = f cos(theta_o) 4 sigma / ndf`` with ``f = table.eval(wi, wo)``
  at the direction the warp maps ``s`` to, and ``ndf``, ``sigma`` interpolated exactly
  as a reader interpolates them, so a reader reproduces the table at every node;
- ``theta_i``: the table's own incident polar angles, 0 and 90 deg (where ``Table.eval``
  holds its first and last row) and, between neighbours no more than two lobe widths
  apart, :data:`THETA_SUBDIVISIONS` - 1 equally spaced ones (:func:`incident_angles`);
  ``jacobian = 1``;
- ``phi_i``: isotropic tables ``[0]``. Anisotropic tables: their tabulated azimuths
  minus 180 deg (:func:`file_azimuths`). Readers fold an incident direction by the
  surface's mirror symmetries into the span of ``phi_i`` (Mitsuba: into
  ``[-180, -90]`` deg when it spans 90 deg, ``[-180, 0]`` when 180), which the
  stretched distributions have (``D`` depends on ``m_x^2`` and ``m_y^2``); a table whose
  azimuths span ``[0, 90]`` or ``[0, 180]`` deg is served there by a rotation of 180 deg.
"""

from __future__ import annotations

import numpy as np

from vcavity._version import __version__
from vcavity.export import ExportRefused, header_text, order_data
from vcavity.export import rgl_grids as grids
from vcavity.export.marginal2d import Marginal2D
from vcavity.export.tensor_file import write_tensor_file

NAME = "rgl"
SOURCE = "table"
SUFFIX = ".bsdf"
SUMMARY = "RGL measured BSDF, RGB (Mitsuba 3 `measured` plugin, RGB variants; Falcor)"

BODY_FLOOR = 0.25           # cosine share of ndf for facets with a Lambertian body
MIN_FLOOR = 0.01            # for facets without one
THETA_SUBDIVISIONS = 4      # file theta_i nodes per interval of the table's theta_i
AZIMUTH_SUBDIVISIONS = 4    # file phi_i nodes per interval of an anisotropic table's phi_i
_SPANS_DEG = (90.0, 180.0)  # azimuth spans a reader folds onto (reduction 4 and 2)


def prepare(table, request):
    """All fields of the RGB file (see the module doc); refuses what it cannot represent."""
    return build_fields(table, request, colour_field="rgb")


def write(prepared, path) -> None:
    """Write the tensor file."""
    write_tensor_file(path, prepared)


def incident_angles(tabulated, lobe_width: float, subdivisions: int = THETA_SUBDIVISIONS):
    """The file's ``theta_i`` (rad): the tabulated angles, 0 and pi/2, and ``subdivisions - 1``
    equally spaced ones inside each interval no wider than twice ``lobe_width``.

    ``Table.eval`` is linear in ``theta_i`` between tabulated angles and holds the first
    and last row beyond them. A reader blends the colour grids of the two file angles
    around ``theta(wi)``, which are over different warps; with nodes at 0 and pi/2 and
    the extra nodes where two neighbouring lobes overlap, that blend follows
    ``Table.eval``. Across a wider interval ``Table.eval`` blends two separate lobes,
    which the colour grid of one warp cannot resolve: no node is added there.
    """
    nodes = np.unique(np.concatenate([[0.0], np.asarray(tabulated, dtype=np.float64), [np.pi / 2]]))
    angles = []
    for a, b in zip(nodes[:-1], nodes[1:]):
        count = subdivisions if b - a <= 2 * lobe_width else 1
        angles.extend(a + (b - a) * np.arange(count) / count)
    return np.array(angles + [nodes[-1]])


def file_azimuths(table, format_name: str = NAME) -> np.ndarray:
    """``phi_i`` of an anisotropic table's file: its tabulated azimuths minus pi (rad);
    ``format_name`` (``rgl`` or ``rgl-spectral``) is named in refusals.

    Raises
    ------
    ExportRefused
        The azimuths (of the rows with theta_i > 0) do not span exactly [0, 90] or
        [0, 180] deg: a reader folds every incident direction into a span of 90 or 180
        deg and would find no data for the others. Or two neighbours are more than
        :data:`~vcavity.brdf.incidence.MAX_PHI_GAP` apart: ``Table.eval`` (the table API)
        serves no azimuth between them, and the file needs every one of the span.
    """
    from vcavity.brdf.incidence import MAX_PHI_GAP

    oblique = np.asarray(table.theta_i) > 1e-9
    degrees = np.unique(np.round(np.mod(np.degrees(np.asarray(table.phi_i)[oblique]), 360.0), 9))
    listed = ", ".join(f"{d:g}" for d in degrees)
    if degrees.size < 2 or degrees[0] != 0.0 or not any(abs(degrees[-1] - s) < 1e-6 for s in _SPANS_DEG):
        raise ExportRefused(
            f"table {str(table.path)!r}: --format {format_name} of an anisotropic table needs its incident "
            f"azimuths to span 0 to 90 deg (or 0 to 180), e.g. phi_i_deg = [0, 45, 90]; it has "
            f"phi_i_deg {listed}")
    widest = float(np.max(np.diff(degrees)))
    max_gap = float(np.degrees(MAX_PHI_GAP))
    if widest > max_gap + 1e-6:
        raise ExportRefused(
            f"table {str(table.path)!r}: --format {format_name} needs the table at every incident azimuth from 0 to "
            f"{degrees[-1]:g} deg, and an anisotropic table is interpolated only between tabulated azimuths at "
            f"most {max_gap:g} deg apart (the table API's MAX_PHI_GAP); it has phi_i_deg {listed}, a gap of "
            f"{widest:g} deg: add azimuths in between, e.g. phi_i_deg = [0, 90, 180]")
    steps = np.arange(AZIMUTH_SUBDIVISIONS) / AZIMUTH_SUBDIVISIONS
    inner = (degrees[:-1, None] + np.diff(degrees)[:, None] * steps).ravel()
    return np.radians(np.append(inner, degrees[-1])) - np.pi


def build_fields(table, request, colour_field: str, wavelengths=None) -> dict:
    """The tensor-file fields of ``table`` (``colour_field`` ``"rgb"`` or ``"spectra"``).

    Raises
    ------
    ExportRefused
        An order the table lacks or that is zero everywhere; azimuths of an anisotropic
        table a reader cannot use (:func:`file_azimuths`).
    """
    from vcavity.brdf.table_brdf import material_is_isotropic

    brdf, _ = order_data(table, request)
    if not np.any(brdf > 0):
        raise ExportRefused(f"table {str(table.path)!r}: order {request.order_text} is zero everywhere; "
                            "an RGL file cannot hold a BSDF without light")
    isotropic = material_is_isotropic(table.material)
    format_name = NAME if wavelengths is None else f"{NAME}-spectral"
    phi_i = np.array([0.0]) if isotropic else file_azimuths(table, format_name)
    ndf_of_m, floor, lobe_width = _ndf_function(table)
    theta_i = incident_angles(table.theta_i, lobe_width)
    ndf = grids.ndf_grid(ndf_of_m)
    sigma = _sigma_grid(ndf_of_m, isotropic)

    def evaluate(wi, wo):
        if isotropic:
            return table.eval(wi, wo, order=request.order)
        flip = np.array([-1.0, -1.0, 1.0])  # the file's azimuths are the table's minus 180 deg
        return table.eval(wi * flip, wo * flip, order=request.order)

    shape = (phi_i.size, theta_i.size)
    vndf = np.empty(shape + grids.NDF_SHAPE)
    colour = np.empty(shape + (grids.COLOUR_RESOLUTION,) * 2)
    for a, phi in enumerate(phi_i):
        for j, theta in enumerate(theta_i):
            wi = grids.direction(theta, phi)
            vndf[a, j] = grids.vndf_slice(ndf, wi)
            colour[a, j] = grids.colour_slice(evaluate, ndf, sigma, Marginal2D(vndf[a, j]), wi)
    luminance = colour.copy()
    dark = ~np.any(luminance > 0, axis=(2, 3))
    luminance[dark] = 1.0  # a slice without light: any positive density (its colour is 0)
    channels = 3 if wavelengths is None else len(wavelengths)
    fields = {
        "description": _description(table, request, floor),
        "jacobian": np.array([1], dtype=np.uint8),
        "theta_i": theta_i.astype(np.float32),
        "phi_i": phi_i.astype(np.float32),
        "ndf": ndf.astype(np.float32),
        "sigma": sigma.astype(np.float32),
        "vndf": vndf.astype(np.float32),
        "luminance": luminance.astype(np.float32),
        colour_field: np.repeat(colour[:, :, None], channels, axis=2).astype(np.float32),
    }
    if wavelengths is not None:
        fields["wavelengths"] = np.asarray(wavelengths, dtype=np.float32)
    return fields


def _sigma_grid(ndf_of_m, isotropic):
    """``sigma`` at the nodes of :data:`~vcavity.export.rgl_grids.SIGMA_SHAPE` over ``u_wi``."""
    if isotropic:
        theta = grids.u_to_theta(np.linspace(0, 1, grids.SIGMA_SHAPE[1]))
        row = grids.projected_area_isotropic(ndf_of_m)(theta)
        return np.repeat(row[None, :], grids.SIGMA_SHAPE[0], axis=0)
    wi, _, _ = grids.node_directions(grids.SIGMA_SHAPE)
    return grids.projected_area(ndf_of_m, wi.reshape(-1, 3)).reshape(grids.SIGMA_SHAPE)


def _ndf_function(table):
    """``ndf(m)`` of the table's material for unit normals (K, 3), the cosine floor ``w``
    and the distribution's angular lobe width (rad)."""
    from vcavity.compare import material_of_table
    from vcavity.microfacet import registry

    try:
        material = material_of_table(table)
    except ValueError as exc:
        raise ExportRefused(str(exc).splitlines()[0]) from None
    kind = registry.kind_of(material.distribution)
    _, params = registry.params_from(material.distribution, material.distribution_params)
    body = material.facet == "interfaced_lambertian" and float(material.facet_params.get("kd", 0.0)) > 0.0
    floor = BODY_FLOOR if body else MIN_FLOOR
    lobe_width = registry.lobe_width(material.distribution, material.distribution_params)

    def ndf_of_m(m):
        m = np.asarray(m, dtype=np.float64)
        d = registry.evaluate("D", kind, m.reshape(-1, 3), params).reshape(m.shape[:-1])
        return (1 - floor) * np.where(np.isfinite(d), d, 0.0) + floor / np.pi

    return ndf_of_m, floor, lobe_width


def _description(table, request, floor) -> str:
    material = ", ".join(f"{k} = {v}" for k, v in table.material.items())
    order = "f_inf (all orders)" if request.order == 0 else f"f{request.order}"
    return (f"vcavity {__version__} V-cavity BRDF table {header_text(table.path.name)}: {material}; {order}; "
            f"ndf = (1 - {floor}) D + {floor}/pi; seed {table.seed}")
