"""Every bounce order of a V-cavity with specular facets, per sensor cell, without a random
path (physics.md sec. 12): the deterministic model behind ``compare --order K`` and the
``exact`` estimator.

For mirror, conductor and ``kd = 0`` dielectric facets the probability that a walk's path
leaves after exactly ``k`` bounces into cell ``c`` is

    P_k(c) = ∫∫ Σ_slots fraction · survival · [k bounces] [exit in c] du1 du2,

the groove drawn through the distribution's sampler ``(u1, u2) -> m`` of pdf
``D(m)(m.n)`` (physics.md sec. 2) and the entry point integrated in closed form by
:func:`vcavity.analytic.specular_groove.groove_outcomes` (at most four outcomes, each in a
slot whose share of the opening varies continuously with ``m``).

Quadrature. Along each ray ``u2 = const`` (``u1 = sin²(π τ / 2)``, which removes the
square-root behaviour of the sampler at both ends) the integrand is smooth between the
points where a slot's exit direction crosses a cell edge, its bounce count changes, or
the groove changes regime (:data:`~vcavity.analytic.specular_groove.SPLIT_LEFT` ...).
The ray is marched in steps that move no exit direction by more than
:data:`~vcavity.analytic.quadrature.STEP_CELLS` cells, every change is located by
bisection (on the sensor's own binning, so a piece is credited to the cell the walk counts
it in) and each piece gets a Gauss-Legendre rule. Over ``u2`` the ray integrals are
continuous with kinks; pieces of ``u2`` are halved until a rule and its two halves agree
within ``tolerance`` times the piece's width in the L1 norm over all cells and orders.

Error estimate. Per cell and order, the sum of the accepted halving differences (the
azimuthal error) plus the change when the radial rule is halved; both are differences
between a rule and a coarser one, reported as the error of the finer (conservative where
the rules converge; tests/analytic/test_specular_orders.py forces a coarse rule and
checks the estimate against a much finer one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import prange

from vcavity._numba.jit import njit
from vcavity.analytic import specular_groove as sg
from vcavity.analytic.quadrature import MAX_STEP, STEP_CELLS
from vcavity.analytic.single_bounce import ModelNotApplicable
from vcavity.facet import registry as facets
from vcavity.microfacet import registry as distributions
from vcavity.sensor.binning import direction_to_cell

#: Gauss-Legendre nodes per ``u2`` piece and per ``τ`` piece.
DEFAULT_AZIMUTH_NODES = 6
DEFAULT_RADIAL_NODES = 6
#: Default L1 tolerance (over all cells and orders, in probability per path) per unit of u2.
DEFAULT_TOLERANCE = 1e-5
#: Starting pieces of ``u2``, and the most halvings and pieces of the adaptive rule.
START_PIECES = 16
MAX_DEPTH = 22
MAX_PIECES = 1 << 14
#: Bisection of a state change stops below this width in ``τ``.
BISECTION_WIDTH = 1e-10
#: Largest ``u1`` (the sampler's deepest groove the quadrature reaches).
_U1_MAX = 1.0 - 2.0 ** -53
_HALF_PI = 0.5 * math.pi
_TRUNCATED = -2  # key of a slot whose path exceeds the bounce cap
_DARK = -1  # key of an empty slot (no entry has this outcome)


@njit(cache=True)
def _point(tau, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit, max_bounces,
           max_order, resolution, buf, keys, values, dirs):
    """Outcomes of the groove at ``(τ, u2)``: per slot its key, value and exit direction.

    ``keys[s]`` is ``row * n_cells + cell`` (row ``min(n, max_order + 1) - 1``: orders
    ``1 .. max_order`` and the rest), :data:`_TRUNCATED` or :data:`_DARK`; ``keys[N_SLOTS]``
    the groove's regime. ``values[s]`` is ``fraction · survival · du1/dτ``.
    """
    s = math.sin(_HALF_PI * tau)
    u1 = min(s * s, _U1_MAX)
    tan_m, cos_phi, sin_phi = distributions.sample(dist_kind, u1, u2, params)
    # d = -i in the groove frame x' = (cos φ, sin φ, 0), y' = (-sin φ, cos φ, 0) (sec. 5)
    dx = -(ix * cos_phi + iy * sin_phi)
    dy = -(iy * cos_phi - ix * sin_phi)
    dz = -iz
    keys[sg.N_SLOTS] = sg.groove_outcomes(buf, tan_m, dx, dz, facet_kind, facet_data, unit, max_bounces)
    jacobian = _HALF_PI * math.sin(math.pi * tau)
    n_cells = resolution * resolution
    for slot in range(sg.N_SLOTS):
        fraction = buf[slot, sg.FRACTION]
        values[slot] = fraction * buf[slot, sg.SURVIVAL] * jacobian
        ex, ez = buf[slot, sg.EXIT_X], buf[slot, sg.EXIT_Z]
        # back to the world frame; the component along the groove is the incoming one
        ox = ex * cos_phi - dy * sin_phi
        oy = ex * sin_phi + dy * cos_phi
        dirs[slot, 0], dirs[slot, 1], dirs[slot, 2] = ox, oy, ez
        if not fraction > 0.0:
            keys[slot] = _DARK
            continue
        n = int(buf[slot, sg.BOUNCES])
        if n > max_bounces:
            keys[slot] = _TRUNCATED
        elif ez > 0.0:
            row = min(n, max_order + 1) - 1
            keys[slot] = row * n_cells + direction_to_cell(ox, oy, ez, resolution)
        else:  # only through rounding at the horizon: nothing to credit
            keys[slot] = _DARK


@njit(cache=True)
def _same(a, b):
    for k in range(a.shape[0]):
        if a[k] != b[k]:
            return False
    return True


@njit(cache=True)
def _piece(idx, val, count, keys, t0, t1, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit,
           max_bounces, max_order, resolution, gl_x, gl_w, buf, keys_tmp, values, dirs, n_keys):
    """Append the Gauss-Legendre integral over ``[t0, t1]`` of each lit slot (state ``keys``)."""
    if t1 <= t0:
        return count
    half = 0.5 * (t1 - t0)
    centre = 0.5 * (t1 + t0)
    acc = np.zeros(sg.N_SLOTS)
    for j in range(gl_x.shape[0]):
        _point(centre + half * gl_x[j], u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit,
               max_bounces, max_order, resolution, buf, keys_tmp, values, dirs)
        for slot in range(sg.N_SLOTS):
            acc[slot] += gl_w[j] * values[slot]
    for slot in range(sg.N_SLOTS):
        key = keys[slot]
        if key == _DARK or acc[slot] == 0.0:
            continue
        if count < idx.shape[0]:
            idx[count] = n_keys - 1 if key == _TRUNCATED else key
            val[count] = half * acc[slot]
        count += 1
    return count


@njit(cache=True)
def _moved(dirs_a, dirs_b, keys_a):
    """How far the exit directions of the slots lit at the step's start moved."""
    moved = 0.0
    for slot in range(sg.N_SLOTS):
        if keys_a[slot] >= 0:
            d = math.sqrt((dirs_b[slot, 0] - dirs_a[slot, 0]) ** 2 + (dirs_b[slot, 1] - dirs_a[slot, 1]) ** 2
                          + (dirs_b[slot, 2] - dirs_a[slot, 2]) ** 2)
            moved = max(moved, d)
    return moved


@njit(cache=True)
def _ray(u2, incident, dist_kind, params, facet_kind, facet_data, unit, max_bounces, max_order, resolution,
         gl_x, gl_w, idx, val, n_keys):
    """Integrals over ``τ`` of one ray, appended to ``idx``/``val``; returns their count."""
    ix, iy, iz = incident[0], incident[1], incident[2]
    buf = np.empty((sg.N_SLOTS, sg.N_FIELDS))
    keys_a = np.empty(sg.N_SLOTS + 1, np.int64)
    keys_b = np.empty(sg.N_SLOTS + 1, np.int64)
    keys_m = np.empty(sg.N_SLOTS + 1, np.int64)
    keys_tmp = np.empty(sg.N_SLOTS + 1, np.int64)
    values = np.empty(sg.N_SLOTS)
    values_b = np.empty(sg.N_SLOTS)
    dirs_a = np.empty((sg.N_SLOTS, 3))
    dirs_b = np.empty((sg.N_SLOTS, 3))
    dirs_m = np.empty((sg.N_SLOTS, 3))
    step_max = STEP_CELLS / resolution
    count = 0
    tau = 0.0
    _point(0.0, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit, max_bounces, max_order,
           resolution, buf, keys_a, values, dirs_a)
    h = MAX_STEP
    while tau < 1.0:
        tb = min(tau + h, 1.0)
        _point(tb, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit, max_bounces, max_order,
               resolution, buf, keys_b, values_b, dirs_b)
        if _moved(dirs_a, dirs_b, keys_a) > step_max and tb - tau > 1e-12:
            h = 0.5 * (tb - tau)
            continue
        # cut [tau, tb] where the state changes (each change bracketed, then bisected)
        t0 = tau
        keys_m[:] = keys_a
        for _ in range(256):  # a few changes per step; the bound keeps it finite
            if _same(keys_m, keys_b):
                break
            lo, hi = t0, tb
            while hi - lo > BISECTION_WIDTH:
                mid = 0.5 * (lo + hi)
                _point(mid, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit, max_bounces,
                       max_order, resolution, buf, keys_tmp, values, dirs_m)
                if _same(keys_tmp, keys_m):
                    lo = mid
                else:
                    hi = mid
            count = _piece(idx, val, count, keys_m, t0, hi, u2, ix, iy, iz, dist_kind, params, facet_kind,
                           facet_data, unit, max_bounces, max_order, resolution, gl_x, gl_w, buf, keys_tmp,
                           values, dirs_m, n_keys)
            t0 = hi
            _point(hi, u2, ix, iy, iz, dist_kind, params, facet_kind, facet_data, unit, max_bounces, max_order,
                   resolution, buf, keys_m, values, dirs_m)
        count = _piece(idx, val, count, keys_m, t0, tb, u2, ix, iy, iz, dist_kind, params, facet_kind,
                       facet_data, unit, max_bounces, max_order, resolution, gl_x, gl_w, buf, keys_tmp, values,
                       dirs_m, n_keys)
        tau = tb
        keys_a[:] = keys_b
        dirs_a[:] = dirs_b
        values[:] = values_b
        h = min(2.0 * h, MAX_STEP)
    return count


@njit(cache=True, parallel=True)
def _rays(u2_nodes, incident, dist_kind, params, facet_kind, facet_data, unit, max_bounces, max_order,
          resolution, gl_x, gl_w, capacity, n_keys):
    """Sparse ``(key, value)`` integrals of every ray; ``counts[r] > capacity``: overflow."""
    n = u2_nodes.shape[0]
    idx = np.zeros((n, capacity), np.int64)
    val = np.zeros((n, capacity))
    counts = np.zeros(n, np.int64)
    for r in prange(n):
        counts[r] = _ray(u2_nodes[r], incident, dist_kind, params, facet_kind, facet_data, unit, max_bounces,
                         max_order, resolution, gl_x, gl_w, idx[r], val[r], n_keys)
    return idx, val, counts


#: The facet models whose hits can be pure specular reflections or absorptions.
SPECULAR_FACETS = ("mirror", "conductor", "interfaced_lambertian")


def is_specular(material) -> bool:
    """True when every facet hit of ``material`` reflects specularly or absorbs: mirror,
    conductor, or interfaced Lambertian with ``kd = 0`` (no body) and ``eta > 1``."""
    return (material.facet in SPECULAR_FACETS and facets.has_specular(material.facet, material.facet_params)
            and facets.body_factor(material.facet, material.facet_params) == 0.0)


@dataclass(frozen=True)
class SpecularOrders:
    """Cell integrals of every order and their error estimates (probabilities per path).

    ``integrals[k - 1, c]`` is ``P_k(c)`` for ``k = 1 .. max_order``; row ``max_order``
    holds the orders beyond it (up to the bounce cap): f_inf is the sum of all rows.
    ``brdf = integrals / Ω⊥_c``. ``error`` has the same shape (conservative estimates);
    ``truncated`` is the share of paths the walk's cap would truncate.
    """

    integrals: np.ndarray
    error: np.ndarray
    truncated: float
    truncated_error: float
    max_order: int
    max_bounces: int

    @property
    def exited(self) -> float:
        """Share of the paths that leave the groove (all orders)."""
        return float(self.integrals.sum())

    @property
    def absorbed(self) -> float:
        """Share of the paths absorbed by the facets (``1 - exited - truncated``)."""
        return max(0.0, 1.0 - self.exited - self.truncated)


class _Rule:
    """The sparse ray integrals of pieces of ``u2`` for one incident direction."""

    def __init__(self, material, incident, resolution, max_order, max_bounces):
        self.incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
        self.kind, self.params = distributions.params_from(material.distribution, material.distribution_params)
        self.facet_kind, _, self.facet_data = facets.prepare(material.facet, material.facet_params)
        self.unit = material.facet == "mirror"
        self.resolution = int(resolution)
        self.max_order = int(max_order)
        self.max_bounces = int(max_bounces)
        self.n_cells = self.resolution ** 2
        self.n_keys = (self.max_order + 1) * self.n_cells + 1  # the last key: truncated
        self.capacity = 2048
        self.rays = 0  # rays traced so far (for benchmarks)

    def pieces(self, lo, hi, n_azimuth, n_radial):
        """Per piece ``[lo_k, hi_k]`` of u2, the sparse integral: ``(piece, key, value)``."""
        x, w = np.polynomial.legendre.leggauss(int(n_azimuth))
        half = 0.5 * (hi - lo)[:, None]
        nodes = (0.5 * (hi + lo)[:, None] + half * x[None, :]) % 1.0
        weights = (half * w[None, :]).ravel()
        self.rays += weights.size
        gl_x, gl_w = np.polynomial.legendre.leggauss(int(n_radial))
        while True:
            idx, val, counts = _rays(np.ascontiguousarray(nodes.ravel()), self.incident, self.kind, self.params,
                                     self.facet_kind, self.facet_data, self.unit, self.max_bounces,
                                     self.max_order, self.resolution, gl_x, gl_w, self.capacity, self.n_keys)
            if counts.max(initial=0) <= self.capacity:
                break
            self.capacity = int(2 ** math.ceil(math.log2(counts.max())))
        used = np.arange(self.capacity)[None, :] < counts[:, None]
        ray = np.broadcast_to(np.arange(counts.size)[:, None], used.shape)[used]
        piece = ray // int(n_azimuth)
        code = piece.astype(np.int64) * self.n_keys + idx[used]
        unique, inverse = np.unique(code, return_inverse=True)
        sums = np.bincount(inverse, weights=val[used] * weights[ray], minlength=unique.size)
        return unique // self.n_keys, unique % self.n_keys, sums


def _sparse_sum(parts, n_keys):
    """Sum of sparse ``(piece, key, value)`` parts, by ``(piece, key)``."""
    piece = np.concatenate([p for p, _, _ in parts])
    key = np.concatenate([k for _, k, _ in parts])
    value = np.concatenate([v for _, _, v in parts])
    code = piece * n_keys + key
    unique, inverse = np.unique(code, return_inverse=True)
    return unique // n_keys, unique % n_keys, np.bincount(inverse, weights=value, minlength=unique.size)


def specular_orders(material, incident, sensor, max_order, max_bounces, *, tolerance=DEFAULT_TOLERANCE,
                    n_azimuth=DEFAULT_AZIMUTH_NODES, n_radial=DEFAULT_RADIAL_NODES, refine=True):
    """Cell integrals of every bounce order of a specular V-cavity, with error estimates.

    Parameters
    ----------
    material : vcavity.config.Material
        Validated material whose facets are specular (:func:`is_specular`).
    incident : array_like (3,)
        Unit direction toward the light, ``z > 0``.
    sensor : vcavity.sensor.grid.EqualAreaSensor
    max_order : int
        Orders ``1 .. max_order`` are returned one by one, the rest summed.
    max_bounces : int
        The walk's bounce cap: paths of more bounces are truncated, as in the walk.
    tolerance : float, keyword-only
        L1 accuracy over all cells and orders (probability per path) of the azimuthal
        rule; the radial rule's error is estimated, not refined.
    n_azimuth, n_radial : int, keyword-only
        Gauss-Legendre nodes per piece of ``u2`` and of ``τ``.
    refine : bool, keyword-only
        False: the starting pieces of ``u2`` only, each checked once against its halves
        (a forced coarse rule whose estimate the tests hold against a fine one).

    Returns
    -------
    SpecularOrders

    Raises
    ------
    ModelNotApplicable
        The facets are not specular, or the incident direction is at or below the horizon.
    """
    if not is_specular(material):
        raise ModelNotApplicable(f"the every-order model needs specular facets (mirror, conductor, "
                                 f"interfaced_lambertian with kd = 0), not {material.facet} "
                                 f"{dict(material.facet_params)}")
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    if not incident[2] > 0.0:
        raise ModelNotApplicable(f"incident direction at or below the horizon (z = {incident[2]:g})")
    rule = _Rule(material, incident, sensor.resolution, max_order, max_bounces)
    n_keys = rule.n_keys
    lo = np.arange(START_PIECES) / START_PIECES
    hi = lo + 1.0 / START_PIECES
    whole = rule.pieces(lo, hi, n_azimuth, n_radial)
    total, error, accepted = [], [], []
    for depth in range(MAX_DEPTH + 1):
        mid = 0.5 * (lo + hi)
        p, k, v = rule.pieces(np.concatenate([lo, mid]), np.concatenate([mid, hi]), n_azimuth, n_radial)
        refined = (p % lo.size, k, v)  # the two halves of piece j are pieces j and j + n
        wp, wk, wv = whole
        dp, dk, dv = _sparse_sum([refined, (wp, wk, -wv)], n_keys)
        l1 = np.bincount(dp, weights=np.abs(dv), minlength=lo.size)
        done = l1 <= tolerance * (hi - lo)
        if not refine or depth == MAX_DEPTH or 2 * np.count_nonzero(~done) > MAX_PIECES:
            done[:] = True
        keep = done[refined[0]]
        total.append((refined[1][keep], refined[2][keep]))
        keep_d = done[dp]
        error.append((dk[keep_d], np.abs(dv[keep_d])))
        accepted.append((lo[done], hi[done]))
        if np.all(done):
            break
        # the halves of the pieces not done are the next round's pieces, their sums the wholes
        todo = np.flatnonzero(~done)
        renumber = np.full(lo.size, -1)
        renumber[todo] = np.arange(todo.size)
        half_of = np.where(p < lo.size, 0, 1)
        parent = p % lo.size
        sel = renumber[parent] >= 0
        whole = (renumber[parent[sel]] + todo.size * half_of[sel], k[sel], v[sel])
        lo, hi = np.concatenate([lo[todo], mid[todo]]), np.concatenate([mid[todo], hi[todo]])
    integrals = _dense(total, n_keys)
    err = _dense(error, n_keys)
    if int(n_radial) >= 2:  # radial error: the accepted pieces with half the tau nodes
        a = np.concatenate([x for x, _ in accepted])
        b = np.concatenate([y for _, y in accepted])
        m = 0.5 * (a + b)
        _, k, v = rule.pieces(np.concatenate([a, m]), np.concatenate([m, b]), n_azimuth,
                              max(int(n_radial) // 2, 1))
        coarse = _dense([(k, v)], n_keys)
        err = err + np.abs(coarse - integrals)
    shape = (rule.max_order + 1, rule.n_cells)
    return SpecularOrders(integrals=integrals[:-1].reshape(shape), error=err[:-1].reshape(shape),
                          truncated=float(integrals[-1]), truncated_error=float(err[-1]),
                          max_order=rule.max_order, max_bounces=rule.max_bounces)


def _dense(parts, n_keys):
    out = np.zeros(n_keys)
    for key, value in parts:
        np.add.at(out, key, value)
    return out


__all__ = ["specular_orders", "SpecularOrders", "is_specular", "SPECULAR_FACETS", "DEFAULT_TOLERANCE"]
