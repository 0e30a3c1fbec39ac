"""RGL measured-BSDF export (``--format rgl``): the tensor file of Dupuy & Jakob 2018.

Mitsuba 3's ``measured`` plugin (and pbrt-v4's measured BxDF, Falcor) evaluate such a
file as (docs/exports.md, "RGL"; Mitsuba ``src/bsdfs/measured.cpp``)::

    f(wi, wo) cos(theta_o) = R(s) * ndf(u_m) / (4 sigma(u_wi)),   s = vndf^-1(u_m)

with ``m`` the half vector, ``u = (sqrt(2 theta/pi), (phi + pi)/(2 pi))`` the unit-square
coordinates of a direction (the azimuth of ``m`` relative to ``phi_i`` for isotropic
files), ``ndf`` and ``sigma`` bilinear grids over ``u_m`` and ``u_wi``, ``vndf`` a
continuous marginal warp (:mod:`vcavity.export.marginal2d`) of the visible-normal density
``ndf(m) <wi.m>`` and ``R`` the colour grid over the warp's domain ``s`` (``rgb`` here,
``spectra`` in :mod:`vcavity.export.rgl_spectral`), interpolated bilinearly in ``s``.

What this module writes, for an isotropic table:

- ``ndf``: the V-cavity surface's own normal distribution ``D`` (the table's
  distribution, through the registry), mixed with a cosine floor,
  ``ndf = (1 - w) D + w / pi`` (both integrate to 1 against ``cos theta_m``). ``w`` is
  :data:`BODY_FLOOR` for facets with a Lambertian body (their diffuse light leaves where
  ``D(h)`` of a sharp lobe is ~0 and must stay reachable by sampling) and
  :data:`MIN_FLOOR` otherwise (it only keeps ``R`` finite where ``D`` underflows);
- ``sigma``: the projected area ``∫ ndf(m) max(0, wi.m) dω_m`` (radial quadrature with
  the exact azimuthal integral);
- ``vndf``: ``ndf(m) max(0, wi.m)`` times the Jacobian ``u_x sin(theta_m)`` of the
  unit-square map, per tabulated ``theta_i`` (the warp normalises it);
- ``rgb`` (grey: three equal channels) and ``luminance``: at each node ``s`` of the
  colour grid, ``R(s) = f cos(theta_o) 4 sigma / ndf`` with ``f = table.eval(wi, wo)``
  at the direction the warp maps ``s`` to, and ``ndf``, ``sigma`` interpolated exactly
  as a reader interpolates them, so a reader reproduces the table at every node;
- ``theta_i``: the table's own incident polar angles plus, between neighbours no more
  than two lobe widths apart, :data:`THETA_SUBDIVISIONS` - 1 equally spaced ones, where
  :meth:`vcavity.Table.eval` interpolates linearly (a reader blends the colour grids of
  neighbouring ``theta_i``, which are over different warps; the extra nodes make it
  follow ``Table.eval``; see :func:`incident_angles`); beyond the first and last
  tabulated angle readers hold the end values, as ``Table.eval`` does;
  ``phi_i = [0]`` (isotropic); ``jacobian = 1``.

Anisotropic tables are refused (not implemented). Reading the table is plain NumPy; the
distribution ``D`` is evaluated through :mod:`vcavity.microfacet.registry` (Numba).
"""

from __future__ import annotations

import numpy as np

from vcavity import __version__
from vcavity.export import ExportRefused, order_data
from vcavity.export.marginal2d import Marginal2D
from vcavity.export.tensor_file import write_tensor_file

NAME = "rgl"
SOURCE = "table"
SUFFIX = ".bsdf"
SUMMARY = "RGL measured BSDF, RGB (Mitsuba 3 `measured` plugin, RGB variants; Falcor)"

NDF_SHAPE = (64, 64)        # (phi_m, theta_m) nodes of ndf and vndf
SIGMA_SHAPE = (2, 64)       # (phi_i, theta_i) nodes of sigma (isotropic: constant in phi)
COLOUR_RESOLUTION = 128     # N x N nodes of rgb / spectra / luminance over the warp domain
BODY_FLOOR = 0.25           # cosine share of ndf for facets with a Lambertian body
MIN_FLOOR = 0.01            # for facets without one
THETA_SUBDIVISIONS = 4      # file theta_i nodes per interval of the table's theta_i
RADIAL_NODES = 4096         # midpoints in u = sqrt(2 theta / pi) for sigma
_SAMPLE_EPSILON = float(np.finfo(np.float32).eps) / 2   # readers clip samples to [eps, 1 - eps]


def u_to_theta(u):
    """Polar angle of the unit-square coordinate ``u``: ``theta = u^2 pi / 2``."""
    return np.square(u) * (np.pi / 2)


def theta_to_u(theta):
    """Inverse of :func:`u_to_theta`."""
    return np.sqrt(np.asarray(theta) * (2 / np.pi))


def u_to_phi(u):
    """Azimuth of the unit-square coordinate ``u``: ``phi = (2u - 1) pi``."""
    return (2 * np.asarray(u) - 1) * np.pi


def bilinear(grid, x, y):
    """A reader's bilinear interpolation of ``grid`` (H, W) at unit-square points ``(x, y)``."""
    h, w = grid.shape
    x = np.clip(x, 0.0, 1.0) * (w - 1)
    y = np.clip(y, 0.0, 1.0) * (h - 1)
    ix = np.minimum(x.astype(np.int64), w - 2)
    iy = np.minimum(y.astype(np.int64), h - 2)
    tx, ty = x - ix, y - iy
    top = grid[iy, ix] * (1 - tx) + grid[iy, ix + 1] * tx
    bottom = grid[iy + 1, ix] * (1 - tx) + grid[iy + 1, ix + 1] * tx
    return top * (1 - ty) + bottom * ty


def prepare(table, request):
    """All fields of the RGB file (see the module doc); refuses what it cannot represent."""
    return build_fields(table, request, colour_field="rgb")


def write(prepared, path) -> None:
    """Write the tensor file."""
    write_tensor_file(path, prepared)


def build_fields(table, request, colour_field: str, wavelengths=None) -> dict:
    """The tensor-file fields of ``table`` (``colour_field`` ``"rgb"`` or ``"spectra"``).

    Raises
    ------
    ExportRefused
        An anisotropic table, or an order the table lacks.
    """
    from vcavity.brdf import material_is_isotropic

    brdf, _ = order_data(table, request)
    if not material_is_isotropic(table.material):
        raise ExportRefused(f"table {str(table.path)!r}: --format {NAME} export of anisotropic tables "
                            f"(alpha_x = {table.material['alpha_x']}, alpha_y = {table.material['alpha_y']}) "
                            "is not implemented; isotropic tables only")
    if not np.any(brdf > 0):
        raise ExportRefused(f"table {str(table.path)!r}: order {request.order_text} is zero everywhere; "
                            "an RGL file cannot hold a BSDF without light")
    ndf_of_theta, floor, lobe_width = _ndf_function(table)
    theta_i = incident_angles(table.theta_i, lobe_width)
    ndf = _ndf_grid(ndf_of_theta)
    sigma_of = _projected_area(ndf_of_theta)
    sigma = np.repeat(sigma_of(u_to_theta(np.linspace(0, 1, SIGMA_SHAPE[1])))[None, :], SIGMA_SHAPE[0], axis=0)
    vndf = np.empty((1, theta_i.size) + NDF_SHAPE)
    colour = np.empty((theta_i.size, COLOUR_RESOLUTION, COLOUR_RESOLUTION))
    for j, theta in enumerate(theta_i):
        vndf[0, j] = _vndf_slice(ndf_of_theta, theta)
        colour[j] = _colour_slice(table, request.order, ndf, sigma, Marginal2D(vndf[0, j]), theta)
    luminance = colour.copy()
    dark = ~np.any(luminance > 0, axis=(1, 2))
    luminance[dark] = 1.0  # a slice without light: any positive density (its colour is 0)
    channels = 3 if wavelengths is None else len(wavelengths)
    fields = {
        "description": _description(table, request, floor),
        "jacobian": np.array([1], dtype=np.uint8),
        "theta_i": theta_i.astype(np.float32),
        "phi_i": np.array([0.0], dtype=np.float32),
        "ndf": ndf.astype(np.float32),
        "sigma": sigma.astype(np.float32),
        "vndf": vndf.astype(np.float32),
        "luminance": luminance[None].astype(np.float32),
        colour_field: np.repeat(colour[None, :, None], channels, axis=2).astype(np.float32),
    }
    if wavelengths is not None:
        fields["wavelengths"] = np.asarray(wavelengths, dtype=np.float32)
    return fields


def incident_angles(tabulated, lobe_width: float, subdivisions: int = THETA_SUBDIVISIONS):
    """The file's ``theta_i``: the tabulated angles, and ``subdivisions - 1`` equally spaced
    ones inside each interval no wider than twice ``lobe_width`` (rad).

    There ``Table.eval``, linear in ``theta_i``, blends two overlapping lobes into one, and
    the extra nodes make a reader follow it. Across a wider interval the blend is two
    separate lobes, which the colour grid of one warp cannot resolve: no node is added.
    """
    nodes = np.unique(np.asarray(tabulated, dtype=np.float64))
    angles = []
    for a, b in zip(nodes[:-1], nodes[1:]):
        count = subdivisions if b - a <= 2 * lobe_width else 1
        angles.extend(a + (b - a) * np.arange(count) / count)
    return np.array(angles + [nodes[-1]])


def _ndf_function(table):
    """``ndf(theta_m)`` of the table's material (isotropic), the cosine floor ``w`` and the
    distribution's angular lobe width (rad)."""
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

    def ndf_of_theta(theta):
        theta = np.asarray(theta, dtype=np.float64)
        m = np.stack([np.sin(theta).ravel(), np.zeros(theta.size), np.cos(theta).ravel()], axis=1)
        d = registry.evaluate("D", kind, m, params).reshape(theta.shape)
        return (1 - floor) * np.where(np.isfinite(d), d, 0.0) + floor / np.pi

    return ndf_of_theta, floor, lobe_width


def _ndf_grid(ndf_of_theta):
    """``ndf`` nodes over ``(u_phi, u_theta)`` (isotropic: the same in every row)."""
    row = ndf_of_theta(u_to_theta(np.linspace(0, 1, NDF_SHAPE[1])))
    return np.repeat(row[None, :], NDF_SHAPE[0], axis=0)


def _projected_area(ndf_of_theta):
    """``sigma(theta_i) = ∫ ndf(m) max(0, wi.m) dω_m`` as a function of ``theta_i``.

    Midpoints in ``u`` resolve sharp lobes (``theta = u^2 pi/2`` crowds nodes at the pole);
    the azimuthal integral is exact: ``∫ max(0, a + b cos phi) dphi`` is ``2 pi a`` when
    ``a >= b`` and ``2 (a phi0 + b sin phi0)``, ``phi0 = arccos(-a/b)``, otherwise. Divided by
    the same rule's ``∫ ndf cos theta_m dω_m`` (exactly 1), so quadrature error cancels to
    first order.
    """
    u = (np.arange(RADIAL_NODES) + 0.5) / RADIAL_NODES
    theta_m = u_to_theta(u)
    weight = ndf_of_theta(theta_m) * np.sin(theta_m) * (np.pi * u / RADIAL_NODES)  # dθ = π u du
    normalisation = 2 * np.pi * np.sum(weight * np.cos(theta_m))

    def sigma_of(theta_i):
        theta_i = np.asarray(theta_i, dtype=np.float64)[..., None]
        a = np.cos(theta_i) * np.cos(theta_m)
        b = np.sin(theta_i) * np.sin(theta_m)
        with np.errstate(divide="ignore", invalid="ignore"):
            phi0 = np.arccos(np.clip(-a / b, -1.0, 1.0))
        azimuthal = np.where(a >= b, 2 * np.pi * a, 2 * (a * phi0 + b * np.sin(phi0)))
        return np.sum(weight * azimuthal, axis=-1) / normalisation

    return sigma_of


def _half_vectors(u_x, u_y):
    theta_m, phi_m = u_to_theta(u_x), u_to_phi(u_y)
    return np.stack([np.sin(theta_m) * np.cos(phi_m), np.sin(theta_m) * np.sin(phi_m), np.cos(theta_m)], axis=-1)


def _vndf_slice(ndf_of_theta, theta_i):
    """Node values of the visible-normal density at ``theta_i`` over ``(u_phi, u_theta)``."""
    u_y, u_x = np.meshgrid(np.linspace(0, 1, NDF_SHAPE[0]), np.linspace(0, 1, NDF_SHAPE[1]), indexing="ij")
    m = _half_vectors(u_x, u_y)
    wi = np.array([np.sin(theta_i), 0.0, np.cos(theta_i)])
    # density per unit square = density per solid angle x |dω/du| = ... x 2 pi^2 u_x sin(theta_m)
    return ndf_of_theta(u_to_theta(u_x)) * np.maximum(m @ wi, 0.0) * u_x * np.sin(u_to_theta(u_x))


def _colour_slice(table, order, ndf, sigma, warp, theta_i):
    """``R(s)`` at the colour nodes for incident ``theta_i`` (azimuth 0)."""
    n = COLOUR_RESOLUTION
    s_y, s_x = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    s_x = np.clip(s_x, _SAMPLE_EPSILON, 1 - _SAMPLE_EPSILON)
    s_y = np.clip(s_y, _SAMPLE_EPSILON, 1 - _SAMPLE_EPSILON)
    u_x, u_y = warp.sample(s_x, s_y)
    m = _half_vectors(u_x, u_y)
    wi = np.array([np.sin(theta_i), 0.0, np.cos(theta_i)])
    wo = 2 * (m @ wi)[..., None] * m - wi
    cos_o = wo[..., 2]
    f = np.where(cos_o > 0, table.eval(np.broadcast_to(wi, wo.shape), np.where(cos_o[..., None] > 0, wo, [0, 0, 1]),
                                       order=order), 0.0)
    sigma_i = bilinear(sigma, theta_to_u(theta_i), 0.5)
    ndf_m = bilinear(ndf, u_x, u_y)
    with np.errstate(divide="ignore", invalid="ignore"):
        colour = np.where((cos_o > 0) & (ndf_m > 0), f * cos_o * 4 * sigma_i / ndf_m, 0.0)
    return np.nan_to_num(colour, nan=0.0, posinf=0.0)


def _description(table, request, floor) -> str:
    material = ", ".join(f"{k} = {v}" for k, v in table.material.items())
    order = "f_inf (all orders)" if request.order == 0 else f"f{request.order}"
    return (f"vcavity {__version__} V-cavity BRDF table {table.path.name}: {material}; {order}; "
            f"ndf = (1 - {floor}) D + {floor}/pi; seed {table.seed}")
