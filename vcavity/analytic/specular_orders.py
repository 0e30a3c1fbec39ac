"""Every bounce order of a V-cavity with specular facets, per sensor cell, without a random
path (physics.md sec. 13): the deterministic model behind ``compare --order K`` and the
``exact`` estimator.

For mirror, conductor and ``kd = 0`` dielectric facets the probability that a walk's path
leaves after exactly ``k`` bounces into cell ``c`` is

    P_k(c) = ∫∫ Σ_slots fraction · survival · [k bounces] [exit in c] du1 du2,

the groove drawn through the distribution's sampler ``(u1, u2) -> m`` (pdf ``D(m)(m.n)``,
physics.md sec. 2: in ``(u1, u2)`` the grooves are uniform) and the entry point
integrated in closed form by :func:`vcavity.analytic.specular_groove.groove_outcomes` (at
most four outcomes, each in a slot whose share of the opening varies continuously).

Quadrature: a mesh pushed forward onto the sensor (physics.md sec. 13). The square
``(τ, u2)``, ``u1 = sin²(π τ / 2)`` (which removes the sampler's square-root behaviour at
both ends), is cut into ``M x M`` quads, the last row of them halved again and again toward
``τ = 1`` (:func:`tau_nodes`: the deepest grooves change fastest). At each vertex every slot's value (fraction ·
survival), bounce count and exit direction, as a point of the sensor's square in cell
units, are evaluated once. A quad whose four corners share a slot's bounce count carries
the slot's mass (its bilinear interpolant times the exact ``du1/dτ``) to the sensor as
two triangles whose images are taken affine: each image triangle is clipped against the
cells and every clipped polygon gets the exact integral of the linear density over it.
Where a slot's bounce count differs between corners its fraction vanishes at the change
(physics.md sec. 12), and each corner's mass goes to its own cell. Every vertex's mass is
credited somewhere (a cell of its order, or the truncated share), so mirror facets
conserve energy to rounding, and the error of a cell is second order in the mesh width.

Error estimate: the mesh is doubled until the L1 change of every cell of every order,
summed, is within ``tolerance`` of what exits; each cell's estimate is its change at the
last doubling (conservative for a second-order rule, where it is about three times the
error of the finer mesh: tests/analytic/test_specular_orders.py holds it against a much
finer mesh). Every vertex of a mesh is one of the doubled mesh's, which copies it instead of
evaluating it again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from vcavity._numba.arrays import filled
from vcavity._numba.jit import njit
from vcavity.analytic import specular_groove as sg
from vcavity.analytic.batches import check_stop, in_batches
from vcavity.analytic.single_bounce import ModelNotApplicable
from vcavity.analytic.splat import MAX_POLYGON, cell_of, splat_triangle
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.sensor.binning import hemisphere_to_square

#: Default tolerance: L1 change over all cells and orders at the last doubling, relative to
#: the share of paths that exit.
DEFAULT_TOLERANCE = 1e-3
#: Quads per side of the first mesh, and the finest mesh a tolerance may ask for.
START_QUADS = 64
MAX_QUADS = 4096
#: Fixed number of accumulation chunks (sums in a fixed order: the result does not depend
#: on the thread count).
N_CHUNKS = 64
#: The mesh's steps halve toward ``τ = 1`` until ``1 - τ`` is this small (:func:`tau_nodes`):
#: the last interval then holds ``~ (π²/4) TAIL_END²`` (2.5e-12) of the grooves, whose
#: vertex at ``τ = 1`` is often beyond the cap (finer would cost conductors a reflectance per
#: hit of thousands of hits, for nothing a table resolves).
TAIL_END = 1e-6
#: Largest ``u1`` (the sampler's deepest groove the quadrature reaches).
_U1_MAX = 1.0 - 2.0 ** -53
_HALF_PI = 0.5 * math.pi
_MAX_PARTS = 64  # cells of a triangle's box whose integrals are kept between the two passes
#: Vertices of the first batch of a mesh's rows (later batches are sized by time).
_FIRST_VERTICES = 1 << 14


@njit(cache=True, parallel=True)
def _vertex_rows(value, bounces, image, first_row, last_row, taus, u2s, incident, dist_kind, params, facet_kind,
                 facet_data, log_table, unit, max_bounces, resolution, known_row, known_value, known_bounces,
                 known_image):
    """Rows ``first_row .. last_row - 1`` of the vertex arrays ``value``, ``bounces`` and
    ``image`` (per vertex ``(τ, u2)`` and slot: value (fraction · survival), bounce count
    (-1: no such outcome) and the exit direction as a point of the sensor square in cell
    units). Each row is computed on its own: any split into calls gives the same arrays.

    The vertices of the mesh of half the quads are among these (``known_row[r]``: the row of
    ``τ_r`` there, or -1; its ``u2`` nodes are every other one): they are copied from the
    ``known_*`` arrays, not evaluated again."""
    n_u2 = u2s.size
    ix, iy, iz = incident[0], incident[1], incident[2]
    half_n = 0.5 * resolution
    for r in prange(first_row, last_row):
        # not np.zeros / np.full: under parallel=True each is a parallel loop of its own (one
        # more gufunc to compile); each row is set here instead
        filled(value[r], 0.0)
        filled(bounces[r], -1)
        filled(image[r], 0.0)
        buf = np.empty((sg.N_SLOTS, sg.N_FIELDS))
        s = math.sin(_HALF_PI * taus[r])
        u1 = min(s * s, _U1_MAX)
        for q in range(n_u2):
            if known_row[r] >= 0 and q % 2 == 0:
                value[r, q] = known_value[known_row[r], q // 2]
                bounces[r, q] = known_bounces[known_row[r], q // 2]
                image[r, q] = known_image[known_row[r], q // 2]
                continue
            tan_m, cos_phi, sin_phi = distributions.sample(dist_kind, u1, u2s[q], params)
            # d = -i in the groove frame x' = (cos φ, sin φ, 0), y' = (-sin φ, cos φ, 0) (sec. 5)
            dx = -(ix * cos_phi + iy * sin_phi)
            dy = -(iy * cos_phi - ix * sin_phi)
            sg.groove_outcomes(buf, tan_m, dx, -iz, facet_kind, facet_data, log_table, unit, max_bounces)
            for slot in range(sg.N_SLOTS):
                fraction = buf[slot, sg.FRACTION]
                if not fraction > 0.0:
                    continue
                value[r, q, slot] = fraction * buf[slot, sg.SURVIVAL]
                bounces[r, q, slot] = int(buf[slot, sg.BOUNCES])
                ex = buf[slot, sg.EXIT_X]
                # back to the world frame; the component along the groove is the incoming one
                u, v = hemisphere_to_square(ex * cos_phi - dy * sin_phi, ex * sin_phi + dy * cos_phi,
                                            buf[slot, sg.EXIT_Z])
                image[r, q, slot, 0] = (u + 1.0) * half_n
                image[r, q, slot, 1] = (v + 1.0) * half_n


def tau_nodes(n_quads):
    """The τ vertices of an ``n_quads``-quad mesh: equal steps ``h = 1/n_quads`` up to
    ``1 - h``, then steps halving toward 1 (``1 - h 2^-k`` down to :data:`TAIL_END`), then 1.

    Near ``τ = 1`` the sampler's deepest grooves (``tan θ_m`` growing like ``log`` or like
    ``1/(1 - τ)``) move the exit directions and bounce counts ever faster; halving steps
    keep each row's image small, and leave the vertex at ``τ = 1`` (the deepest groove,
    often beyond the bounce cap) a weight of ``~ TAIL_END²`` instead of ``~ h²``.
    """
    h = 1.0 / n_quads
    steps = np.arange(n_quads) * h
    levels = max(int(math.ceil(math.log2(h / TAIL_END))), 1)
    tail = 1.0 - h * 0.5 ** np.arange(1, levels + 1)
    return np.concatenate([steps, tail[tail > steps[-1]], [1.0]])


def tau_weights(nodes):
    """Weights of the hat functions on the τ intervals between ``nodes`` against ``du1/dτ``.

    ``du1/dτ = (π/2) sin(π τ)``; on ``[a, b]`` the weights of the end points are
    ``∫ (b - τ)/(b - a) du1`` and ``∫ (τ - a)/(b - a) du1``, in closed form. Returns
    ``(lo, hi)``, one per interval; over ``[0, 1]`` they sum to 1 (the sampler's whole measure).
    """
    t = np.asarray(nodes, dtype=np.float64)
    a, b = t[:-1], t[1:]
    d = b - a
    mid = np.cos(0.5 * math.pi * (a + b))
    half = np.sin(0.5 * math.pi * d)
    # ∫_a^b (π/2) sin(π τ) dτ = (cos πa - cos πb)/2, as a product (no cancellation)
    mass = np.sin(0.5 * math.pi * (a + b)) * half
    # ∫_a^b (τ - a)(π/2) sin(π τ) dτ = -d cos(πb)/2 + (sin πb - sin πa)/(2π), by parts
    hi = (-0.5 * d * np.cos(math.pi * b) + mid * half / math.pi) / d
    return mass - hi, hi


@njit(cache=True)
def _quad(acc, value, bounces, image, r, q, slot, w_lo, w_hi, max_order, max_bounces, resolution, px, py, qx, qy,
          parts, masses, counts):
    """Credit one slot's mass over the quad with lower-left vertex ``(r, q)``."""
    rr = (r, r + 1, r + 1, r)
    qq = (q, q, q + 1, q + 1)
    w = (w_lo, w_hi, w_hi, w_lo)
    total = 0.0
    same = True
    for k in range(4):
        masses[k] = w[k] * value[rr[k], qq[k], slot]
        counts[k] = bounces[rr[k], qq[k], slot]
        total += masses[k]
        if counts[k] != counts[0]:
            same = False
    if not total > 0.0:
        return
    n_cells = resolution * resolution
    truncated = acc.shape[0] - 1
    if same and counts[0] >= 1:
        n = counts[0]
        if n > max_bounces:
            acc[truncated] += total
            return
        base = (min(n, max_order + 1) - 1) * n_cells
        x0, y0 = image[rr[0], qq[0], slot, 0], image[rr[0], qq[0], slot, 1]
        x1, y1 = image[rr[1], qq[1], slot, 0], image[rr[1], qq[1], slot, 1]
        x2, y2 = image[rr[2], qq[2], slot, 0], image[rr[2], qq[2], slot, 1]
        x3, y3 = image[rr[3], qq[3], slot, 0], image[rr[3], qq[3], slot, 1]
        c0 = cell_of(x0, y0, resolution)
        if (c0 == cell_of(x1, y1, resolution) and c0 == cell_of(x2, y2, resolution)
                and c0 == cell_of(x3, y3, resolution)):
            acc[base + c0] += total
            return
        # two triangles; each carries the quad's mass in proportion to its linear integral
        t_a = masses[0] + masses[1] + masses[2]
        t_b = masses[0] + masses[2] + masses[3]
        share = total / (t_a + t_b)
        splat_triangle(acc, base, x0, y0, x1, y1, x2, y2, masses[0], masses[1], masses[2], t_a * share,
                        resolution, px, py, qx, qy, parts)
        splat_triangle(acc, base, x0, y0, x2, y2, x3, y3, masses[0], masses[2], masses[3], t_b * share,
                        resolution, px, py, qx, qy, parts)
        return
    # the bounce count changes inside the quad, where the slot's fraction vanishes: each
    # corner's mass goes to its own cell
    for k in range(4):
        if not masses[k] > 0.0:
            continue
        n = counts[k]
        if n > max_bounces:
            acc[truncated] += masses[k]
        else:
            acc[(min(n, max_order + 1) - 1) * n_cells
                + cell_of(image[rr[k], qq[k], slot, 0], image[rr[k], qq[k], slot, 1], resolution)] += masses[k]


@njit(cache=True, parallel=True)
def _accumulate_chunks(partial, first_chunk, last_chunk, value, bounces, image, w_lo, w_hi, du2, max_order,
                       max_bounces, resolution):
    """Rows ``[(order, cell) ..., truncated]`` ``first_chunk .. last_chunk - 1`` of ``partial``
    (zeros on entry): each chunk's rows of quads of the mesh, summed in a fixed order. The
    chunks are :data:`N_CHUNKS` fixed ranges of rows, so any split into calls gives the same."""
    n_tau = value.shape[0] - 1
    n_u2 = value.shape[1] - 1
    for chunk in prange(first_chunk, last_chunk):
        px = np.empty(MAX_POLYGON)
        py = np.empty(MAX_POLYGON)
        qx = np.empty(MAX_POLYGON)
        qy = np.empty(MAX_POLYGON)
        parts = np.empty(_MAX_PARTS)
        masses = np.empty(4)
        counts = np.empty(4, np.int64)
        acc = partial[chunk]
        for r in range(chunk * n_tau // N_CHUNKS, (chunk + 1) * n_tau // N_CHUNKS):
            wl = 0.5 * du2 * w_lo[r]
            wh = 0.5 * du2 * w_hi[r]
            for q in range(n_u2):
                for slot in range(sg.N_SLOTS):
                    _quad(acc, value, bounces, image, r, q, slot, wl, wh, max_order, max_bounces, resolution,
                          px, py, qx, qy, parts, masses, counts)


def is_specular(material) -> bool:
    """True when every facet hit of ``material`` reflects specularly or absorbs
    (:func:`vcavity.facet.registry.is_specular`)."""
    return facets.is_specular(material.facet, material.facet_params)


@dataclass(frozen=True)
class SpecularOrders:
    """Cell integrals of every order and their error estimates (probabilities per path).

    ``integrals[k - 1, c]`` is ``P_k(c)`` for ``k = 1 .. max_order``; row ``max_order``
    holds the orders beyond it (up to the bounce cap): f_inf is the sum of all rows.
    ``brdf = integrals / Ω⊥_c``. ``error`` has the same shape (conservative estimates);
    ``truncated`` is the share of paths the walk's cap would truncate. ``quads`` is the
    number of quads per side of the finest mesh; ``converged`` whether the error estimate
    met the tolerance (False: the mesh reached ``max_quads`` first).
    """

    integrals: np.ndarray
    error: np.ndarray
    truncated: float
    truncated_error: float
    max_order: int
    max_bounces: int
    quads: int
    converged: bool = True

    @property
    def exited(self) -> float:
        """Share of the paths that leave the groove (all orders)."""
        return float(self.integrals.sum())

    @property
    def absorbed(self) -> float:
        """Share of the paths absorbed by the facets (``1 - exited - truncated``)."""
        return max(0.0, 1.0 - self.exited - self.truncated)

    def order(self, k: int, beyond: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Cell integrals and error estimates of order ``k`` (0: f_inf, the sum of the rows;
        ``beyond = False`` leaves out the orders beyond ``max_order``, as a walk without
        ``track_all_orders`` stops those paths)."""
        if k >= 1:
            return self.integrals[k - 1], self.error[k - 1]
        rows = slice(None) if beyond else slice(0, self.max_order)
        return self.integrals[rows].sum(axis=0), self.error[rows].sum(axis=0)


def _prepared(material):
    """What every mesh of ``material`` needs: the distribution's and the facet's kernel data,
    the facet's ``log F`` table and whether its reflectance is 1."""
    kind, params = distributions.params_from(material.distribution, material.distribution_params)
    facet_kind, _, facet_data = facets.prepare(material.facet, material.facet_params)
    unit = material.facet == "mirror"
    log_table = np.empty(0) if unit else sg.log_reflectance_table(facet_kind, facet_data)
    return kind, params, facet_kind, facet_data, log_table, unit


def _mesh(prepared, incident, resolution, max_order, max_bounces, n_quads, known=None, should_stop=None):
    """Cell integrals of one mesh, and its vertices (``known``: those of the mesh of
    ``n_quads / 2`` quads, reused).

    The vertices are computed in batches of rows and the quads in batches of the
    :data:`N_CHUNKS` chunks (:func:`vcavity.analytic.batches.in_batches`: short compiled
    calls, ``should_stop`` polled between them); the result does not depend on the batches.
    """
    kind, params, facet_kind, facet_data, log_table, unit = prepared
    n_quads = int(n_quads)
    taus = tau_nodes(n_quads)
    u2s = np.arange(n_quads + 1) / n_quads
    known_row = np.full(taus.size, -1, np.int64)
    if known is not None and 2 * (known[1].shape[1] - 1) == n_quads:
        known_taus = known[0]
        at = np.minimum(np.searchsorted(known_taus, taus), known_taus.size - 1)
        known_row = np.where(known_taus[at] == taus, at, -1)
    else:
        empty = np.zeros((0, 0, sg.N_SLOTS))
        known = (None, empty, empty.astype(np.int64), np.zeros((0, 0, sg.N_SLOTS, 2)))
    incident = np.ascontiguousarray(incident, dtype=np.float64)
    value = np.empty((taus.size, u2s.size, sg.N_SLOTS))
    bounces = np.empty((taus.size, u2s.size, sg.N_SLOTS), np.int64)
    image = np.empty((taus.size, u2s.size, sg.N_SLOTS, 2))
    threads = numba.get_num_threads()

    def vertex_rows(first, last):
        _vertex_rows(value, bounces, image, first, last, taus, u2s, incident, kind, params, facet_kind,
                     facet_data, log_table, unit, int(max_bounces), int(resolution), known_row, *known[1:])

    in_batches(taus.size, max(1, _FIRST_VERTICES // u2s.size), vertex_rows, should_stop, minimum=threads)
    w_lo, w_hi = tau_weights(taus)
    partial = np.zeros((N_CHUNKS, (int(max_order) + 1) * int(resolution) ** 2 + 1))

    def chunks(first, last):
        _accumulate_chunks(partial, first, last, value, bounces, image, w_lo, w_hi, 1.0 / n_quads, int(max_order),
                           int(max_bounces), int(resolution))

    in_batches(N_CHUNKS, threads, chunks, should_stop, minimum=threads)
    integrals = np.zeros(partial.shape[1])
    for chunk in range(N_CHUNKS):  # in chunk order, element by element: the same sums for any threads
        integrals += partial[chunk]
    return integrals, (taus, value, bounces, image)


def mesh_integrals(material, incident, resolution, max_order, max_bounces, n_quads):
    """Cell integrals ``[(order, cell) ..., truncated]`` on one ``n_quads x n_quads`` mesh."""
    return _mesh(_prepared(material), incident, resolution, max_order, max_bounces, n_quads)[0]


def specular_orders(material, incident, sensor, max_order, max_bounces, *, tolerance=DEFAULT_TOLERANCE,
                    start_quads=START_QUADS, max_quads=MAX_QUADS, rows=None, should_stop=None):
    """Cell integrals of every bounce order of a specular V-cavity, with error estimates.

    Parameters
    ----------
    material : vcavity.material.Material
        Validated material whose facets are specular (:func:`is_specular`).
    incident : array_like (3,)
        Unit direction toward the light, ``z > 0``.
    sensor : vcavity.sensor.grid.EqualAreaSensor
    max_order : int
        Orders ``1 .. max_order`` are returned one by one, the rest summed.
    max_bounces : int
        The walk's bounce cap: paths of more bounces are truncated, as in the walk.
    tolerance : float, keyword-only
        The mesh is doubled until its last doubling changed the cells of all orders by at
        most ``tolerance`` times the exiting share, in L1 (``inf``: the first mesh only).
    start_quads, max_quads : int, keyword-only
        Quads per side of the first mesh, and of the finest one allowed: when that is
        reached first, the estimate says how far from the tolerance it is.
    rows : sequence of int, keyword-only
        The rows (``k - 1`` for order ``k``, ``max_order`` for the orders beyond) whose
        L1 change, relative to their own sum, the tolerance measures; default all rows,
        relative to what exits. (A test of one order needs that order's accuracy only.)
    should_stop : callable, keyword-only
        Polled between the short compiled calls of each mesh (:mod:`vcavity.analytic.batches`);
        True stops the computation.

    Returns
    -------
    SpecularOrders

    Raises
    ------
    ModelNotApplicable
        The facets are not specular, or the incident direction is at or below the horizon.
    vcavity.analytic.batches.ModelInterrupted
        ``should_stop`` returned True.
    """
    if not is_specular(material):
        raise ModelNotApplicable(f"the every-order model needs specular facets (mirror, conductor, "
                                 f"interfaced_lambertian with kd = 0), not {material.facet} "
                                 f"{dict(material.facet_params)}")
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    if not incident[2] > 0.0:
        raise ModelNotApplicable(f"incident direction at or below the horizon (z = {incident[2]:g})")
    shape = (int(max_order) + 1, sensor.resolution ** 2)
    measured = np.zeros(shape[0], bool)
    measured[slice(None) if rows is None else list(rows)] = True
    def part(a):  # the measured rows' sum
        return a[:-1].reshape(shape)[measured].sum()

    prepared = _prepared(material)
    n = max(int(start_quads), 2)
    coarse, known = _mesh(prepared, incident, sensor.resolution, max_order, max_bounces, n // 2,
                          should_stop=should_stop)
    while True:
        check_stop(should_stop)
        fine, known = _mesh(prepared, incident, sensor.resolution, max_order, max_bounces, n, known, should_stop)
        change = np.abs(fine - coarse)
        converged = bool(part(change) <= tolerance * part(fine))
        if converged or 2 * n > max_quads:
            break
        coarse, n = fine, 2 * n
    return SpecularOrders(integrals=fine[:-1].reshape(shape), error=change[:-1].reshape(shape),
                          truncated=float(fine[-1]), truncated_error=float(change[-1]),
                          max_order=int(max_order), max_bounces=int(max_bounces), quads=n, converged=converged)


def compile_model(material) -> None:
    """Compile (or load from the cache) the compiled functions :func:`specular_orders` calls
    for ``material`` (specular facets), on the smallest meshes of a one-cell sensor: what a
    run does before its models, so that their time is the model's own (the compile's is
    reported apart). Every specular material's calls have the same argument types; the
    facet's reflectance table is compiled for facets other than mirrors only."""
    specular_orders(material, np.array([0.6, 0.0, 0.8]), _OneCell(), 1, 2, tolerance=math.inf, start_quads=2,
                    max_quads=2)


class _OneCell:
    """What :func:`specular_orders` reads of a sensor, for :func:`compile_model`."""

    resolution = 1


__all__ = ["specular_orders", "compile_model", "mesh_integrals", "tau_nodes", "tau_weights", "SpecularOrders", "is_specular",
           "DEFAULT_TOLERANCE"]
