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
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from vcavity._version import __version__
from vcavity.export import ExportRefused, ExportRequest
from vcavity.io.schema import order_name, orders_text
from vcavity.sweep.albedo import albedo, albedo_stderr, order_position, stderr_rule

NAME = "albedo-lut"
SOURCE = "sweep"
SUFFIX = ".npz"
SUMMARY = "albedo look-up tables E(mu, alpha), E_avg(alpha) of f1 and an order: .npz or C header .h"
CONTAINERS = (".npz", ".h")
#: Largest |mu - (i + 0.5)/n| accepted as a midpoint grid (theta_i_deg written with 6 decimals
#: is within 1e-8 of it; an error of 1e-6 in a node moves E_avg by less than 1e-6 / n).
MU_TOLERANCE = 1e-6
ROUGHNESS = "alpha"
INCIDENCE = "theta_i_deg"
QUADRATURE = ("E_avg = 2 / n_mu * sum_i E(mu_i) mu_i: the midpoint rule over n_mu equal bins of [0, 1], "
              "mu_i = (i + 0.5) / n_mu")
LAYOUT = "E[alpha index][mu index]; mu = cos(theta_i) ascending, alpha ascending"
#: The tables in file order; the stderr ones only where the estimator gives an error.
TABLES = ("E_f1", "E", "E_f1_stderr", "E_stderr", "E_avg_f1", "E_avg", "E_avg_f1_stderr", "E_avg_stderr")


@dataclass(frozen=True)
class AlbedoLut:
    """What :func:`write` writes (arrays in float64; the C header rounds them to float).

    ``tables`` maps names (``E_f1``, ``E``, ``E_f1_stderr``, ``E_stderr``: (n_alpha, n_mu);
    ``E_avg_f1``, ``E_avg``, ``E_avg_f1_stderr``, ``E_avg_stderr``: (n_alpha,)) to arrays;
    the stderr entries are missing where the sweep's estimator gives none.
    """

    container: str
    mu: np.ndarray
    alpha: np.ndarray
    theta_i_deg: np.ndarray
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


def _lut_grid(sweep, values: np.ndarray, alpha_order, mu_order) -> np.ndarray:
    """A grid array reduced to (alpha, mu): the single-valued axes dropped, alpha rows, mu
    columns, both in ascending order."""
    names = [a.name for a in sweep.axes]
    index = tuple(slice(None) if n in (ROUGHNESS, INCIDENCE) else 0 for n in names)
    reduced = values[index]
    if names.index(ROUGHNESS) > names.index(INCIDENCE):  # file order (theta_i_deg, alpha)
        reduced = reduced.T
    return reduced[np.ix_(alpha_order, mu_order)]


def prepare(sweep, request: ExportRequest) -> AlbedoLut:
    """Check the sweep and compute the tables (module docstring).

    Raises
    ------
    ExportRefused
        One line: a suffix other than .npz or .h; no theta_i_deg or alpha axis; another axis
        with several values; points not done; order 1 or the requested order missing; mu
        not at the midpoints of equal bins; non-finite albedos.
    """
    suffix = request.output.suffix.lower() if request.output is not None else SUFFIX
    if suffix not in CONTAINERS:
        raise ExportRefused(f"FILE = {str(request.output)!r}: --format albedo-lut writes {' or '.join(CONTAINERS)} "
                            f"(NumPy arrays or a C header), chosen by the suffix; not {suffix or '(none)'!r}")
    shown = repr(str(sweep.path)) if sweep.path is not None else "(in memory)"
    _refuse_axes(sweep, shown)
    done = np.asarray(sweep.data["done"])
    if np.any(done != 1):
        spec = sweep.attrs.get("source") or "SWEEP.toml"
        out = sweep.path if sweep.path is not None else "OUT.h5"
        raise ExportRefused(f"sweep {shown}: {int(np.sum(done != 1))} of {done.size} points are not done; "
                            f"run vcavity sweep {spec} -o {out} --resume first")
    have = orders_text(sweep.order)
    if order_position(sweep, 1) is None:
        raise ExportRefused(f"sweep {shown}: has no order 1 (orders {have}); the LUT always holds E_f1")
    if order_position(sweep, request.order) is None:
        need = " (sweep with track_all_orders = true)" if request.order == 0 else ""
        raise ExportRefused(f"--order = {request.order_text!r}: sweep {shown} has orders {have}{need}")
    axis = {a.name: a for a in sweep.axes}
    theta = np.asarray(axis[INCIDENCE].values, dtype=np.float64)
    mu_order, mu = _midpoint_mu(theta, shown)
    alpha_values = np.asarray(axis[ROUGHNESS].values, dtype=np.float64)
    alpha_order = np.argsort(alpha_values, kind="stable")

    def grid(values):
        return _lut_grid(sweep, np.asarray(values), alpha_order, mu_order)

    tables = {}
    for name, order in (("f1", 1), ("", request.order)):
        suffix_name = f"_{name}" if name else ""
        values = grid(albedo(sweep, order))
        if not np.all(np.isfinite(values)):
            raise ExportRefused(f"sweep {shown}: albedo of {order_name(order)} holds non-finite values "
                                "although every point is done: the file is damaged")
        tables[f"E{suffix_name}"] = values
        tables[f"E_avg{suffix_name}"] = midpoint_average(values, mu)
        error = albedo_stderr(sweep, order)
        if error is not None:
            tables[f"E{suffix_name}_stderr"] = grid(error)
            tables[f"E_avg{suffix_name}_stderr"] = midpoint_average_stderr(grid(error), mu)
    tables = {name: tables[name] for name in TABLES if name in tables}
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
        "order": order_name(request.order),
        "estimator": estimator,
        "stderr": stderr_rule(estimator),
        "quadrature": QUADRATURE,
        "layout": LAYOUT,
        "paths_range": f"{int(paths.min())} .. {int(paths.max())} paths per incident direction",
    }
    return AlbedoLut(container=suffix, mu=mu, alpha=alpha_values[alpha_order], theta_i_deg=theta[mu_order],
                     paths=paths, tables=tables, metadata=metadata)


def write(lut: AlbedoLut, path) -> None:
    """Write ``lut`` at ``path`` as its container says (``.npz`` or ``.h``)."""
    if lut.container == ".h":
        with open(path, "w", encoding="utf-8") as stream:
            stream.write(c_header(lut))
        return
    arrays = {"mu": lut.mu, "alpha": lut.alpha, "theta_i_deg": lut.theta_i_deg, "paths": lut.paths, **lut.tables}
    arrays.update({key: np.array(value) for key, value in lut.metadata.items()})
    with open(path, "wb") as stream:  # a file object: np.savez would append .npz to a name
        np.savez(stream, **arrays)


def _c_float(value: float) -> str:
    """``%.9g`` (round-trips a float) as a C float literal: ``0.5f``, ``1.0f``, ``1e-05f``."""
    text = f"{float(value):.9g}"
    if not any(c in text for c in ".e"):
        text += ".0"
    return text + "f"


def _c_array(name: str, values: np.ndarray, dims: str) -> str:
    if values.ndim == 1:
        body = ", ".join(_c_float(v) for v in values)
        return f"static const float {name}{dims} = {{{body}}};\n"
    rows = ",\n".join("    {" + ", ".join(_c_float(v) for v in row) + "}" for row in values)
    return f"static const float {name}{dims} = {{\n{rows}\n}};\n"


def c_header(lut: AlbedoLut) -> str:
    """The ``.h`` text: metadata and axes as comments, sizes as macros, ``static const float``
    arrays ``vcavity_lut_mu``, ``vcavity_lut_alpha``, ``vcavity_<table>``."""
    meta = lut.metadata
    lines = ["/* Albedo look-up tables for energy compensation (Kulla & Conty 2017), written by",
             f" * vcavity {meta['vcavity_version']} (vcavity export --format albedo-lut).", " *"]
    lines += [f" * {key}: {str(value).replace('*/', '* /')}" for key, value in meta.items()]
    lines += [f" * E = albedo of {meta['order']}; E_f1 = albedo of f1 (single scattering).",
              # the axes in full double precision (repr: shortest round trip); the arrays are floats
              " * theta_i_deg (as simulated, mu ascending): " + ", ".join(repr(float(t)) for t in lut.theta_i_deg),
              " * mu = cos(theta_i): " + ", ".join(repr(float(m)) for m in lut.mu),
              " * alpha: " + ", ".join(repr(float(a)) for a in lut.alpha), " */",
              "#ifndef VCAVITY_ALBEDO_LUT_H", "#define VCAVITY_ALBEDO_LUT_H", "",
              f"#define VCAVITY_LUT_N_MU {lut.mu.size}", f"#define VCAVITY_LUT_N_ALPHA {lut.alpha.size}", ""]
    text = "\n".join(lines) + "\n"
    text += _c_array("vcavity_lut_mu", lut.mu, "[VCAVITY_LUT_N_MU]")
    text += _c_array("vcavity_lut_alpha", lut.alpha, "[VCAVITY_LUT_N_ALPHA]")
    for name, values in lut.tables.items():
        dims = "[VCAVITY_LUT_N_ALPHA][VCAVITY_LUT_N_MU]" if values.ndim == 2 else "[VCAVITY_LUT_N_ALPHA]"
        text += "\n" + _c_array(f"vcavity_{name}", values, dims)
    return text + "\n#endif /* VCAVITY_ALBEDO_LUT_H */\n"
