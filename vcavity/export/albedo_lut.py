"""``--format albedo-lut``: directional and average albedo tables for energy compensation.

From a sweep over roughness ``alpha`` and incident angle ``theta_i_deg`` (``mu = cos
theta_i``) it writes the directional albedo ``E(mu, alpha)`` of f1 (single scattering) and
of the requested order (default f_inf, every order), and their cosine-weighted averages

    E_avg(alpha) = 2 * integral_0^1 E(mu, alpha) mu dmu,

the tables renderers use for multiple-scattering energy compensation (Kulla and Conty
2017, "Revisiting physically based shading at Imageworks"; Cycles and OSPRay ship 32 x 32
``E`` tables and a 32-entry ``E_avg`` table). Only the simulated grid is written: no
interpolation, no extrapolation. Rows are alpha, columns mu, both ascending.

``E_avg`` uses the **midpoint rule**: it needs the grid's mu values to be the midpoints
``(i + 0.5) / n`` of ``n`` equal bins of [0, 1] (within :data:`MU_TOLERANCE`), and is then
``E_avg = 2 / n * sum_i E(mu_i) mu_i``; its error is at most ``h^2 / 24 * max |g''|``
with ``g(mu) = 2 mu E(mu)`` and ``h = 1 / n``. Other mu grids are refused.

Containers, picked by the output's suffix: ``.npz`` (NumPy arrays and metadata strings) or
``.h`` (a C header of ``static const float`` arrays). docs/exports.md, *Albedo LUT*.

``--layout cycles`` writes the same tables on Blender Cycles' node grids and in its order
(:mod:`vcavity.export.albedo_cycles`; also ``.npy``). ``--orders 1 2 3 inf`` writes the
albedo of each listed order and the remainder (:func:`vcavity.export.lut_common.table_specs`)
in either layout.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from vcavity._version import __version__
from vcavity.export import ExportRefused, ExportRequest, header_text
from vcavity.export import albedo_cycles as cycles
from vcavity.export.lut_common import albedo_tables, c_array, orders_label, select, table_specs
from vcavity.io.schema import order_name, orders_text
from vcavity.sweep.albedo import order_position, stderr_rule

NAME = "albedo-lut"
SOURCE = "sweep"
SUFFIX = ".npz"
SUMMARY = ("albedo look-up tables E(mu, alpha), E_avg(alpha) of f1 and an order (or --orders): .npz or C "
           "header .h; --layout cycles: Blender Cycles' grids and order, also .npy")
CONTAINERS = (".npz", ".h")
LAYOUTS = ("vcavity", "cycles")
#: Largest |mu - (i + 0.5)/n| accepted as a midpoint grid (theta_i_deg written with 6 decimals
#: is within 1e-8 of it; an error of 1e-6 in a node moves E_avg by less than 1e-6 / n).
MU_TOLERANCE = 1e-6
ROUGHNESS = "alpha"
INCIDENCE = "theta_i_deg"
QUADRATURE = ("E_avg = 2 / n_mu * sum_i E(mu_i) mu_i: the midpoint rule over n_mu equal bins of [0, 1], "
              "mu_i = (i + 0.5) / n_mu")
LAYOUT = "E[alpha index][mu index]; mu = cos(theta_i) ascending, alpha ascending"


@dataclass(frozen=True)
class AlbedoLut:
    """What :func:`write` writes (arrays in float64; the C header rounds them to float).

    ``tables`` maps names (``E_f1``, ``E``, ``E_f1_stderr``, ``E_stderr``: (n_alpha, n_mu),
    or (32 mu, 32 r) in the Cycles layout; ``E_avg_f1``, ``E_avg``, ``E_avg_f1_stderr``,
    ``E_avg_stderr``: (n_alpha,); with ``--orders``: ``E_f2``, ``E_rest``, ...) to arrays;
    the stderr entries are missing where the sweep's estimator gives none. ``axes``: the
    coordinates (``mu``, ``alpha``, ``theta_i_deg``; Cycles: also ``r``).
    """

    container: str
    layout: str
    axes: dict
    paths: np.ndarray
    tables: dict
    metadata: dict = field(default_factory=dict)


def _refuse_axes(sweep, shown: str) -> None:
    """The LUT is E(mu, alpha): a theta_i_deg axis, an alpha axis, nothing else varying."""
    names = [a.name for a in sweep.axes]
    if INCIDENCE not in names:
        raise ExportRefused(f"sweep {shown}: has no theta_i_deg axis; the albedo LUT is E(mu, alpha) with "
                            "mu = cos(theta_i): sweep theta_i_deg")
    x, y = sweep.material.get("alpha_x"), sweep.material.get("alpha_y")
    if x is not None and y is not None and x != y:
        raise ExportRefused(f"sweep {shown}: material alpha_x = {x:g}, alpha_y = {y:g} is anisotropic; the "
                            "albedo LUT is E(mu, alpha) of isotropic materials: sweep alpha")
    if ROUGHNESS not in names:
        anisotropic = [n for n in ("alpha_x", "alpha_y") if n in names]
        if anisotropic:
            raise ExportRefused(f"sweep {shown}: roughness axis {anisotropic[0]} is anisotropic roughness; the "
                                "albedo LUT is E(mu, alpha) of isotropic materials: sweep alpha "
                                "(alpha_x = alpha_y = alpha)")
        raise ExportRefused(f"sweep {shown}: has no alpha axis; the albedo LUT is E(mu, alpha): sweep "
                            "alpha (a distribution with roughness alpha: beckmann, ggx, student_t)")
    varying = [a for a in sweep.axes if a.name not in (ROUGHNESS, INCIDENCE) and len(a.values) > 1]
    if varying:
        listed = ", ".join(f"axis {a.name} has {len(a.values)} values" for a in varying)
        one = " and ".join(f"one {a.name}" for a in varying)
        raise ExportRefused(f"sweep {shown}: the LUT is E(mu, alpha); {listed}: sweep {one} per file")


def _midpoint_mu(theta_i_deg: np.ndarray, shown: str) -> tuple[np.ndarray, np.ndarray]:
    """``(order, mu)``: the permutation sorting mu ascending and the sorted mu, refused
    unless they are the midpoints (i + 0.5)/n of n equal bins of [0, 1]."""
    mu = np.cos(np.radians(theta_i_deg))
    order = np.argsort(mu, kind="stable")
    n = mu.size
    expected = (np.arange(n) + 0.5) / n
    worst = float(np.max(np.abs(mu[order] - expected)))
    if not worst <= MU_TOLERANCE:
        hint = ", ".join(f"{math.degrees(math.acos(m)):.6f}" for m in expected[::-1][:3])
        raise ExportRefused(f"sweep {shown}: the mu = cos(theta_i) of its {n} theta_i_deg values are not the "
                            f"midpoints (i + 0.5)/{n} of {n} equal bins of [0, 1] (off by {worst:.3g}), which "
                            f"the midpoint rule for E_avg needs: sweep theta_i_deg = degrees(arccos((i + 0.5)/"
                            f"{n})) = [{hint}, ...]")
    return order, mu[order]


def midpoint_average(values: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """``2 * integral_0^1 E(mu) mu dmu`` by the midpoint rule: ``2 / n * sum_i E_i mu_i``.

    Parameters
    ----------
    values : ndarray (..., n)
        ``E`` at the nodes ``mu`` (last axis).
    mu : ndarray (n,)
        The midpoints ``(i + 0.5) / n``.
    """
    return 2.0 * np.sum(values * mu, axis=-1) / mu.size


def midpoint_average_stderr(stderr: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Standard error of :func:`midpoint_average` for independent errors of the nodes
    (every incident direction has its own random streams)."""
    return 2.0 * np.sqrt(np.sum((stderr * mu) ** 2, axis=-1)) / mu.size


def _check(sweep, request: ExportRequest, shown: str) -> str:
    """The container, after every check that does not depend on the layout's grid."""
    containers = cycles.CONTAINERS if request.layout == "cycles" else CONTAINERS
    suffix = request.output.suffix.lower() if request.output is not None else SUFFIX
    if suffix not in containers:
        layout = f" --layout {request.layout}" if request.layout != "vcavity" else ""
        raise ExportRefused(f"FILE = {str(request.output)!r}: --format albedo-lut{layout} writes "
                            f"{' or '.join(containers)} (NumPy arrays or a C header), chosen by the suffix; not "
                            f"{suffix or '(none)'!r}")
    _refuse_axes(sweep, shown)
    done = np.asarray(sweep.data["done"])
    if np.any(done != 1):
        spec = sweep.attrs.get("source") or "SWEEP.toml"
        out = sweep.path if sweep.path is not None else "OUT.h5"
        raise ExportRefused(f"sweep {shown}: {int(np.sum(done != 1))} of {done.size} points are not done; "
                            f"run vcavity sweep {spec} -o {out} --resume first")
    have = orders_text(sweep.order)
    if request.orders is not None:
        absent = [k for k in request.orders if order_position(sweep, k) is None]
        if absent:
            need = " (sweep with track_all_orders = true)" if 0 in absent else ""
            raise ExportRefused(f"--orders = {' '.join(request.orders_text)}: sweep {shown} has orders {have}, "
                                f"not {', '.join(order_name(k) for k in absent)}{need}")
        return suffix
    if order_position(sweep, 1) is None:
        raise ExportRefused(f"sweep {shown}: has no order 1 (orders {have}); the LUT always holds E_f1")
    if order_position(sweep, request.order) is None:
        need = " (sweep with track_all_orders = true)" if request.order == 0 else ""
        raise ExportRefused(f"--order = {request.order_text!r}: sweep {shown} has orders {have}{need}")
    return suffix


def prepare(sweep, request: ExportRequest) -> AlbedoLut:
    """Check the sweep and compute the tables (module docstring).

    Raises
    ------
    ExportRefused
        One line: a suffix the layout does not write; no theta_i_deg or alpha axis; another
        axis with several values; points not done; order 1 or the requested order(s)
        missing; mu not at the midpoints of equal bins (or, Cycles layout, a node missing);
        non-finite albedos.
    """
    shown = repr(str(sweep.path)) if sweep.path is not None else "(in memory)"
    specs = table_specs(request.order, request.orders)
    container = _check(sweep, request, shown)
    axis = {a.name: a for a in sweep.axes}
    theta = np.asarray(axis[INCIDENCE].values, dtype=np.float64)
    alpha_values = np.asarray(axis[ROUGHNESS].values, dtype=np.float64)
    if request.layout == "cycles":
        r_index, mu_index = cycles.locate(alpha_values, theta, shown)
        r_nodes, mu_nodes = cycles.nodes()

        def grid(values):  # [y: mu, x: r]
            return select(sweep, values, r_index, mu_index).T

        average, average_stderr = cycles.average, cycles.average_stderr
        axes = {"r": r_nodes, "alpha": alpha_values[r_index], "mu": mu_nodes, "theta_i_deg": theta[mu_index]}
        quadrature, layout = cycles.QUADRATURE, cycles.LAYOUT
    else:
        mu_order, mu = _midpoint_mu(theta, shown)
        alpha_order = np.argsort(alpha_values, kind="stable")

        def grid(values):  # [alpha, mu]
            return select(sweep, values, alpha_order, mu_order)

        def average(values):
            return midpoint_average(values, mu)

        def average_stderr(values):
            return midpoint_average_stderr(values, mu)

        axes = {"mu": mu, "alpha": alpha_values[alpha_order], "theta_i_deg": theta[mu_order]}
        quadrature, layout = QUADRATURE, LAYOUT
    tables = albedo_tables(sweep, specs, grid, average, average_stderr, shown)
    paths = grid(sweep.data["paths"]).astype(np.int64)
    single = {a.name: a.values[0] for a in sweep.axes if a.name not in (ROUGHNESS, INCIDENCE)}
    estimator = str(sweep.attrs.get("estimator", "analog"))
    metadata = {
        "format": "vcavity-albedo-lut",
        "vcavity_version": __version__,
        "sweep_vcavity_version": str(sweep.attrs.get("vcavity_version")),
        "sweep_file": str(sweep.path.name) if sweep.path is not None else "",
        "sweep_seed": str(sweep.attrs.get("seed")),
        "material": json.dumps({**sweep.material, **single, **sweep.scalars}, sort_keys=True, default=str),
        "order": order_name(request.order) if request.orders is None else "see tables",
        "tables": orders_label(specs),
        "estimator": estimator,
        "stderr": stderr_rule(estimator),
        "quadrature": quadrature,
        "layout": layout,
        "paths_range": f"{int(paths.min())} .. {int(paths.max())} paths per incident direction",
    }
    return AlbedoLut(container=container, layout=request.layout, axes=axes, paths=paths, tables=tables,
                     metadata=metadata)


def write(lut: AlbedoLut, path) -> None:
    """Write ``lut`` at ``path`` as its container says (``.npz``, ``.h``; Cycles layout: ``.npy``)."""
    if lut.container == ".h":
        with open(path, "w", encoding="utf-8") as stream:
            stream.write(cycles.c_header(lut) if lut.layout == "cycles" else c_header(lut))
        return
    with open(path, "wb") as stream:  # a file object: np.save(z) would append a suffix to a name
        if lut.container == ".npy":
            np.save(stream, cycles.npy_array(lut))
        elif lut.layout == "cycles":
            np.savez(stream, **cycles.npz_arrays(lut))
        else:
            arrays = {**lut.axes, "paths": lut.paths, **lut.tables}
            np.savez(stream, **arrays, **{key: np.array(value) for key, value in lut.metadata.items()})


def c_header(lut: AlbedoLut) -> str:
    """The ``.h`` text: metadata and axes as comments, sizes as macros, ``static const float``
    arrays ``vcavity_lut_mu``, ``vcavity_lut_alpha``, ``vcavity_<table>``."""
    meta, mu, alpha = lut.metadata, lut.axes["mu"], lut.axes["alpha"]
    lines = ["/* Albedo look-up tables for energy compensation (Kulla & Conty 2017), written by",
             f" * vcavity {meta['vcavity_version']} (vcavity export --format albedo-lut).", " *"]
    lines += [f" * {key}: {header_text(value).replace('*/', '* /')}" for key, value in meta.items()]
    if "E_f1" in lut.tables and "E" in lut.tables and meta["order"] != "see tables":
        lines.append(f" * E = albedo of {meta['order']}; E_f1 = albedo of f1 (single scattering).")
    lines += [  # the axes in full double precision (repr: shortest round trip); the arrays are floats
              " * theta_i_deg (as simulated, mu ascending): "
              + ", ".join(repr(float(t)) for t in lut.axes["theta_i_deg"]),
              " * mu = cos(theta_i): " + ", ".join(repr(float(m)) for m in mu),
              " * alpha: " + ", ".join(repr(float(a)) for a in alpha), " */",
              "#ifndef VCAVITY_ALBEDO_LUT_H", "#define VCAVITY_ALBEDO_LUT_H", "",
              f"#define VCAVITY_LUT_N_MU {mu.size}", f"#define VCAVITY_LUT_N_ALPHA {alpha.size}", ""]
    text = "\n".join(lines) + "\n"
    text += c_array("vcavity_lut_mu", mu, "[VCAVITY_LUT_N_MU]")
    text += c_array("vcavity_lut_alpha", alpha, "[VCAVITY_LUT_N_ALPHA]")
    for name, values in lut.tables.items():
        dims = "[VCAVITY_LUT_N_ALPHA][VCAVITY_LUT_N_MU]" if values.ndim == 2 else "[VCAVITY_LUT_N_ALPHA]"
        text += "\n" + c_array(f"vcavity_{name}", values, dims)
    return text + "\n#endif /* VCAVITY_ALBEDO_LUT_H */\n"
