"""``--kind versus``: two tabulations of one material side by side, and their difference.

``vcavity plot A.h5 B.h5`` (two tables; ``--kind versus`` is then the default) or
``vcavity plot SWEEP.h5 --kind versus --point alpha=0.6 [--versus microsurface]`` (two
points of a sweep file, :mod:`vcavity.plots.sides`). Meant for the V-cavity against the
Smith microsurface of one material (docs/microsurfaces.md), it compares any two tables of
one material (two seeds, two estimators). Drawn:

- the albedo per order against theta_i of both (error bars ±2 standard errors, the
  binomial rule of :mod:`vcavity.sweep.albedo`), and below it ``B - A`` with ±2 sigma,
  sigma the quadrature sum of both standard errors (independent runs);
- per incident direction, the in-plane slices (phi_o = phi_i and phi_i + 180 deg, signed
  theta_o as ``--kind slice``) of f1, f2 and f_inf of both, and below them ``B - A`` per
  cell the plane crosses with its band of ±2 sigma (quadrature sum of ``brdf_stderr``).

Refused in one line: materials that differ in anything but the microsurface (unless
``--force``: then the title says what differs), other sensor resolutions, no incident
direction in common, an order one side lacks. :func:`versus_data` computes the numbers
without matplotlib; :func:`render` draws them (:mod:`vcavity.plots.versus_figure`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vcavity.io.schema import order_name, orders_text
from vcavity.plots.request import PlotError, check_output, parse_order, select_theta, sort_orders
from vcavity.plots.sides import differences_text

NAME = "versus"
#: Draws two sources: two tables, or two points of one sweep file.
SOURCE = "pair"
SCALES = ("log", "linear")
DEFAULT_SCALE = "log"
DEFAULT_ORDERS = (1, 2, 0)
MODELS = ()
#: Keys of ``/material`` that may differ between the sides without ``--force``.
FREE_KEYS = ("microsurface",)


@dataclass(frozen=True)
class VersusRequest:
    """A checked ``--kind versus`` request: the two sides and what to draw of them.

    ``indices`` are pairs ``(j_a, j_b)`` of incidence indices of the same direction;
    ``differs`` maps each material key that differs (``--force``) to ``(a, b)``.
    """

    kind: str
    output: object
    sides: tuple
    indices: tuple
    orders: tuple
    scale: str
    differs: dict
    models: tuple = ()


@dataclass(frozen=True)
class VersusData:
    """The numbers of a versus plot; every difference is ``B - A``.

    Attributes
    ----------
    labels : (str, str)
    orders : tuple of int
        0 = f_inf.
    theta_i_deg, phi_i_deg : ndarray (n,)
        The directions drawn (common to both sides).
    albedo, albedo_stderr : (dict, dict)
        Per side, order -> (n,) albedo and its standard error (None where the estimator
        gives none).
    albedo_difference, albedo_difference_stderr : dict
        Order -> (n,) ``albedo_B - albedo_A`` and ``hypot(stderr_A, stderr_B)`` (None if
        either side has none).
    slices : list of (SliceData, SliceData)
        Per direction, the in-plane slices of A and B (:func:`vcavity.plots.data.slice_data`).
    difference, difference_stderr : list of dict
        Per direction, order -> ``brdf_B - brdf_A`` along the slice's stretches and
        ``hypot`` of the two slices' standard errors.
    differs : dict
        Material keys that differ (a ``--force`` comparison): key -> (A's, B's).
    """

    labels: tuple
    orders: tuple
    theta_i_deg: np.ndarray
    phi_i_deg: np.ndarray
    albedo: tuple
    albedo_stderr: tuple
    albedo_difference: dict
    albedo_difference_stderr: dict
    slices: list
    difference: list
    difference_stderr: list
    differs: dict


def _same(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=0.0)
    return a == b


def material_differences(a: dict, b: dict, free=FREE_KEYS) -> dict:
    """Keys of two ``/material`` dicts (other than ``free``) whose values differ:
    key -> (A's, B's), a missing key as None."""
    keys = [k for k in dict.fromkeys([*a, *b]) if k not in free]
    return {k: (a.get(k), b.get(k)) for k in keys if not _same(a.get(k), b.get(k))}


def _common_directions(a, b) -> list:
    """Pairs ``(j_a, j_b)`` of the same (theta_i_deg, phi_i_deg) within 1e-6 deg, in A's order."""
    pairs = []
    for j in range(len(a.theta_i_deg)):
        hits = np.flatnonzero(np.isclose(b.theta_i_deg, a.theta_i_deg[j], rtol=0.0, atol=1e-6)
                              & np.isclose(b.phi_i_deg, a.phi_i_deg[j], rtol=0.0, atol=1e-6))
        if hits.size:
            pairs.append((j, int(hits[0])))
    return pairs


def _angles(side) -> str:
    return ", ".join(f"{t:g}/{p:g}" for t, p in zip(side.theta_i_deg, side.phi_i_deg))


def check(a, b, output=None, theta_i_deg=None, orders=None, scale=None, overwrite=False, force=False,
          default_output=None, sources=()) -> VersusRequest:
    """Check a versus request on two :class:`~vcavity.plots.sides.Side`, computing nothing.

    Parameters
    ----------
    a, b : vcavity.plots.sides.Side
    output : path, optional
        Default ``default_output``.
    theta_i_deg, orders, scale, overwrite
        As :func:`vcavity.plots.check_request`; ``theta_i_deg`` picks among the common directions.
    force : bool
        Compare materials that differ in more than the microsurface.
    default_output : pathlib.Path
    sources : sequence of path
        The input files: never the output.

    Raises
    ------
    PlotError
        One line (module docstring).
    """
    # two points of a sweep differ by design in what the compared axis sets
    differs = material_differences(a.material, b.material, FREE_KEYS + tuple(a.compared) + tuple(b.compared))
    if differs and not force:
        raise PlotError(f"{a.label} and {b.label} are different materials ({differences_text(differs)}); "
                        "--kind versus compares one material (the microsurface may differ); --force to draw "
                        "them anyway")
    if a.sensor.resolution != b.sensor.resolution:
        raise PlotError(f"{a.label} has a {a.sensor.resolution}x{a.sensor.resolution} sensor, {b.label} "
                        f"{b.sensor.resolution}x{b.sensor.resolution}: cells differ, nothing to subtract "
                        "(run both with the same sensor_resolution)")
    pairs = _common_directions(a, b)
    if not pairs:
        raise PlotError(f"{a.label} and {b.label} share no incident direction (theta_i/phi_i deg: "
                        f"{_angles(a)} against {_angles(b)})")
    present = [k for k in (int(o) for o in a.order) if k in set(int(o) for o in b.order)]
    if orders:
        chosen = tuple(dict.fromkeys(parse_order(o) for o in orders))
        for k in chosen:
            for side in (a, b):
                if k not in set(int(o) for o in side.order):
                    raise PlotError(f"--order = {'f_inf' if k == 0 else k}: {side.label} has orders "
                                    f"{orders_text(side.order)}")
    else:
        chosen = tuple(k for k in DEFAULT_ORDERS if k in present)
        if not chosen:
            raise PlotError(f"{a.label} and {b.label} have no order of {', '.join(map(order_name, DEFAULT_ORDERS))}"
                            f" in common ({orders_text(a.order)} against {orders_text(b.order)}); choose with --order")
    theta = np.array([a.theta_i_deg[ja] for ja, _ in pairs])
    picked = select_theta(theta, theta_i_deg, f"both {a.label} and {b.label}")
    # the output last: what to draw is reported first, whatever the output's state
    if output is None:
        from vcavity.plots.request import default_field

        out, field = default_output, default_field(NAME)
    else:
        out, field = output, "-o"
    for source in sources or (None,):
        out = check_output(out, overwrite, source, field)
    return VersusRequest(kind=NAME, output=out, sides=(a, b), indices=tuple(pairs[i] for i in picked),
                         orders=sort_orders(chosen), scale=scale or DEFAULT_SCALE, differs=differs)


def versus_data(a, b, pairs, orders, differs=None) -> VersusData:
    """The numbers of a versus plot (see :class:`VersusData`).

    Parameters
    ----------
    a, b : vcavity.plots.sides.Side
    pairs : sequence of (int, int)
        Incidence indices ``(j_a, j_b)`` of each direction drawn.
    orders : sequence of int
    differs : dict, optional
        Carried into :attr:`VersusData.differs`.
    """
    from vcavity.plots.data import slice_data

    ja = np.array([p[0] for p in pairs], dtype=np.int64)
    jb = np.array([p[1] for p in pairs], dtype=np.int64)
    albedo, errors = ({}, {}), ({}, {})
    difference, difference_stderr = {}, {}
    for k in orders:
        for s, (side, rows) in enumerate(((a, ja), (b, jb))):
            albedo[s][k] = np.asarray(side.albedo[rows, side.order_index(k)], dtype=np.float64)
            error = side.albedo_stderr(k)
            errors[s][k] = None if error is None else np.asarray(error)[rows]
        difference[k] = albedo[1][k] - albedo[0][k]
        difference_stderr[k] = (None if errors[0][k] is None or errors[1][k] is None
                                else np.hypot(errors[0][k], errors[1][k]))
    slices, along, along_stderr = [], [], []
    for j_a, j_b in pairs:
        first, second = slice_data(a, j_a, orders), slice_data(b, j_b, orders)
        slices.append((first, second))
        along.append({k: second.brdf[k] - first.brdf[k] for k in orders})
        along_stderr.append({k: np.hypot(first.stderr[k], second.stderr[k]) for k in orders})
    return VersusData(labels=(a.label, b.label), orders=tuple(orders), theta_i_deg=a.theta_i_deg[ja].copy(),
                      phi_i_deg=a.phi_i_deg[ja].copy(), albedo=albedo, albedo_stderr=errors,
                      albedo_difference=difference, albedo_difference_stderr=difference_stderr, slices=slices,
                      difference=along, difference_stderr=along_stderr, differs=dict(differs or {}))


def render(_source, request: VersusRequest):
    """Draw a checked request; returns ``(figure, VersusData)``."""
    from vcavity.plots.versus_figure import versus_figure  # matplotlib loads only when drawn

    a, b = request.sides
    data = versus_data(a, b, request.indices, request.orders, request.differs)
    return versus_figure(a, b, data, scale=request.scale), data


__all__ = ["DEFAULT_ORDERS", "FREE_KEYS", "VersusData", "VersusRequest", "check", "differences_text",
           "material_differences", "render", "versus_data"]
