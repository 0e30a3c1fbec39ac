"""Every path through one V-groove with specular facets, in closed form (physics.md sec. 12).

With mirror, conductor or ``kd = 0`` dielectric facets a path inside a groove is fixed
by its entry point ``x'`` on the opening: no random number decides anything but whether
light survives each hit (probability ``F`` there). Unfolding the groove into the fan of
its mirror images turns the path into a straight line (Zipin 1966; Lee et al. 2018,
Xie and Hanrahan 2018), from which this module reads, for the whole opening at once,

- the entry intervals that share one outcome: light that hits the left wall first
  leaves after ``n`` or ``n + 1`` bounces, never more than two counts per side, so a
  groove has at most four outcomes;
- each outcome's bounce count, exit direction, the cosines of its hits and so the
  product of the facet reflectances along it.

Geometry (groove frame of :mod:`vcavity.kernels.groove`: opening ``z = 0, x' in [-1, 1]``,
vertex ``V = (0, -T)``, ``T = tan θ_m``). Seen from ``V`` the right wall points at the
angle ``θ = θ_m`` and the left wall at ``π - θ``: the groove is the wedge
``[θ, θ + β]``, ``β = π - 2θ``. The fan's wedges are ``[a_j, a_j + β]`` with spokes
``a_j = θ + jβ``; the opening's images are the sides of a regular polygon of apothem
``T`` and circumradius ``L = sec θ``. A line travelling in the in-plane direction
``c = (cos φ_d, sin φ_d)`` rotates about ``V`` counter-clockwise when it passes left of
``V`` (``x' < x_V = T c_x/c_z``; it hits the left wall first) and clockwise otherwise.
Every spoke it crosses inside the polygon is one bounce, so a path leaving through the
polygon side of wedge ``j`` had ``|j|`` bounces. For the counter-clockwise side:

- the line through ``V`` leaves at the angle ``φ_d`` itself;
- the line through a polygon vertex ``C_k`` (angle ``a_k``) is a chord of the
  circumcircle and leaves through the side under its far end, at the angle
  ``b = 2 φ_d - π - a_k`` (mod ``2π``, beyond ``a_k``), unless it points out of the
  circle there: then it leaves through the side right after the vertex;
- between these the exit point moves monotonically along the polygon, over less than
  one wedge: at most one vertex ``C_k`` separates two outcomes, at the entry point
  ``x' = x_V + L sin(φ_d - a_k)/c_z`` of the line through it.

The hit at spoke ``a_b`` has the 3-D cosine ``s |sin(φ_d - a_b)|`` to the wall normal
(``s`` the in-plane length of the unit direction: unfolding keeps angles, and the
component along the groove never changes). Leaving from wedge ``j`` the direction is
unfolded back: its in-plane angle is ``φ_d - jβ`` for even ``j`` (a rotation) and
``2θ + (j + 1)β - φ_d`` for odd ``j`` (a reflection). The clockwise side is the mirror
image ``x' -> -x'``.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity._numba.jit import njit
from vcavity.facet import registry as facets

#: Slots of a groove's outcomes: the side of the first hit (left 0, right 1) times the
#: parity of the bounce count. The two counts of one side differ by one, so each outcome
#: has a slot of its own, and an outcome keeps its slot while the groove changes: a slot
#: empties (its fraction reaching 0) exactly where its count changes by two.
N_SLOTS = 4
# fields of one slot in the outcome array
FRACTION = 0  # share of the opening (of the entry points) with this outcome
BOUNCES = 1  # bounce count n >= 1
EXIT_X = 2  # in-plane exit direction in the groove frame: x', z (the y' part is the
EXIT_Z = 3  # incoming one, unchanged)
SURVIVAL = 4  # product of the facet reflectances over min(n, max_bounces) hits
N_FIELDS = 5
#: Regime bits of :func:`groove_outcomes`: where the outcome's pieces change form.
SPLIT_LEFT = 1  # the left-first entries have two bounce counts
SPLIT_RIGHT = 2  # the right-first entries have two bounce counts
VERTEX_INSIDE = 4  # the line through the vertex enters through the opening (both sides lit)

_TWO_PI = 2.0 * math.pi
#: A survival below this is 0 (:func:`_survival`): 1e-12 of a path, below the noise of any
#: table (a 1e9-path table resolves 1e-9); all such paths together are at most 1e-12 of the light.
NEGLIGIBLE_SURVIVAL = 1e-12


@njit(cache=True, inline="always")
def _wedge(phi, theta, beta):
    """Index ``j`` of the fan wedge ``[θ + jβ, θ + (j + 1)β)`` holding the angle ``phi``."""
    return math.floor((phi - theta) / beta)


@njit(cache=True, inline="always")
def _exit_angle(j, phi_d, theta, beta):
    """In-plane angle of the real exit direction of a path leaving from wedge ``j``."""
    if j % 2 == 0:
        return phi_d - j * beta
    return 2.0 * theta + (j + 1) * beta - phi_d


@njit(cache=True, inline="always")
def _rim_wedge(a_k, phi_d, theta, beta):
    """Exit wedge of the counter-clockwise line through the polygon vertex at angle ``a_k``.

    When ``c`` points into the circumcircle there, the line is a chord whose far end
    ``b = a_k + ((2 (φ_d - a_k) - π) mod 2π)`` lies beyond the polygon side it leaves
    through; otherwise the line only grazes the polygon at the vertex and leaves through
    the side that follows it (entries beside the rim hit the wall next to it and leave at
    once). At least 1: every path bounces.
    """
    delta = phi_d - a_k
    if math.cos(delta) >= 0.0:
        j = _wedge(a_k + 0.5 * beta, theta, beta)
    else:
        j = _wedge(a_k + ((2.0 * delta - math.pi) % _TWO_PI), theta, beta)
    return max(j, 1)


#: Largest error accepted of the interpolated ``log F`` (:func:`log_reflectance_table`): the
#: relative error of one reflectance factor, so a product of 10^4 factors is within 1e-8.
LOG_TABLE_ERROR = 1e-12
#: Node counts tried for the table, finest last; beyond it F is evaluated at every hit.
LOG_TABLE_SIZES = (4096, 8192, 16384, 32768, 65536)
_LOG_NEGLIGIBLE = math.log(NEGLIGIBLE_SURVIVAL)
#: Check points per table interval (:func:`log_reflectance_table`).
_TABLE_CHECKS = 8


@njit(cache=True)
def _reflectances(cos, facet_kind, facet_data):
    out = np.empty(cos.size)
    for i in range(cos.size):
        out[i] = facets.reflectance(facet_kind, cos[i], facet_data)
    return out


@njit(cache=True, inline="always")
def _interpolated(table, c):
    """Cubic Lagrange interpolation of ``table`` (values at ``c = i/N``, ``i = 0 .. N``) at ``c``."""
    n = table.size - 1
    x = c * n
    i = min(max(int(x), 1), n - 2)
    t = x - i
    tm, t1, t2 = t + 1.0, t - 1.0, t - 2.0
    return (-t * t1 * t2 * table[i - 1] + 3.0 * tm * t1 * t2 * table[i]
            - 3.0 * tm * t * t2 * table[i + 1] + tm * t * t1 * table[i + 2]) / 6.0


def log_reflectance_table(facet_kind, facet_data):
    """``log F`` of the facet at ``N + 1`` equally spaced cosines, for :func:`groove_outcomes`.

    A survival is a product of up to thousands of reflectances (deep grooves), each one an
    exact Fresnel evaluation, costly for a conductor. A table of ``log F`` read by cubic
    interpolation costs a fraction of that (docs/performance.md, "Figures from the code's
    comments"); ``N`` is the smallest of :data:`LOG_TABLE_SIZES`
    whose interpolant is within :data:`LOG_TABLE_ERROR` of the exact ``log F`` at
    ``8 N`` check points (Fresnel reflectances of the specular facets are smooth on
    ``[0, 1]``: 4096 nodes suffice for metals and dielectrics of everyday indices).

    Returns
    -------
    ndarray
        The table, or an empty array when none of the sizes is accurate enough (extreme
        indices, where ``log F`` changes steeply near grazing): then every hit's ``F`` is
        evaluated exactly.
    """
    for n in LOG_TABLE_SIZES:  # F evaluated at each size's own check points: most facets stop at 4096
        with np.errstate(divide="ignore"):
            sample = np.log(_reflectances(np.linspace(0.0, 1.0, n * _TABLE_CHECKS + 1), facet_kind, facet_data))
        if not np.all(np.isfinite(sample)):
            break
        table = sample[::_TABLE_CHECKS]
        error = np.abs(_interpolated_array(table, np.linspace(0.0, 1.0, sample.size)) - sample)
        if np.max(error) <= LOG_TABLE_ERROR:
            return np.ascontiguousarray(table)
    return np.empty(0)


@njit(cache=True)
def _interpolated_array(table, c):
    out = np.empty(c.size)
    for i in range(c.size):
        out[i] = _interpolated(table, c[i])
    return out


@njit(cache=True)
def _log_survival(log_sum, first, last, s, phi_d, theta, beta, facet_kind, facet_data, log_table):
    """``log_sum`` plus ``log F(s |sin(φ_d - a_b)|)`` of the spokes ``b = first .. last``.

    ``log F`` from ``log_table`` (:func:`log_reflectance_table`), or exactly when it is
    empty. Stops early, returning a value below ``log`` :data:`NEGLIGIBLE_SURVIVAL`, once
    the sum falls there (what is left of such a path is below any table's resolution, and
    deep grooves would otherwise cost a reflectance per hit).
    """
    for b in range(first, last + 1):
        if log_sum < _LOG_NEGLIGIBLE:
            break
        cos_hit = min(s * abs(math.sin(phi_d - (theta + b * beta))), 1.0)
        if log_table.size > 0:
            log_sum += _interpolated(log_table, cos_hit)
        else:
            f = facets.reflectance(facet_kind, cos_hit, facet_data)
            log_sum += math.log(f) if f > 0.0 else -math.inf
    return log_sum


@njit(cache=True, inline="always")
def _survival(log_sum):
    """The survival of a log sum; below :data:`NEGLIGIBLE_SURVIVAL` it is 0."""
    return math.exp(log_sum) if log_sum >= _LOG_NEGLIGIBLE else 0.0


@njit(cache=True)
def _one_side(out, slot_base, mirrored, cx, cz, s, tan_m, theta, beta, length, facet_kind, facet_data,
              log_table, unit_reflectance, max_bounces):
    """Outcomes of the entries that turn counter-clockwise (hit the left wall first).

    ``(cx, cz)`` is the unit in-plane direction (``cz < 0``), already mirrored for the
    right side (``mirrored``: flip the exit's x'). Writes the slots
    ``slot_base + parity``; returns True when the side has two bounce counts.
    """
    x_vertex = tan_m * cx / cz
    if not x_vertex > -1.0:  # every entry passes right of V
        return False
    x_hi = min(x_vertex, 1.0)
    phi_e = math.atan2(-cz, -cx)  # angle of -c, in (0, π)
    phi_d = phi_e + math.pi
    # exit wedge of the line through the left rim C_1 (x' = -1) ...
    j_lo = _rim_wedge(theta + beta, phi_d, theta, beta)
    # ... and of the line through V, or through the right rim C_0 when V is not lit
    if x_vertex < 1.0:
        j_hi = max(_wedge(phi_d, theta, beta), 1)  # max: rounding at a spoke
    else:
        j_hi = _rim_wedge(theta, phi_d, theta, beta)
    split = j_lo != j_hi
    if split:
        vertex = max(j_lo, j_hi)  # C_k separates wedges k - 1 and k
        x_break = x_vertex + length * math.sin(phi_d - (theta + vertex * beta)) / cz
        x_break = min(max(x_break, -1.0), x_hi)
        pieces = ((j_lo, x_break + 1.0), (j_hi, x_hi - x_break))
    else:
        pieces = ((j_lo, x_hi + 1.0), (j_lo, 0.0))
    # the side's two counts differ by one: the shorter path's hits are the longer one's first
    j_short = min(j_lo, j_hi)
    log_short = 0.0
    log_long = 0.0
    if not unit_reflectance:
        n_short = min(j_short, max_bounces)
        log_short = _log_survival(0.0, 1, n_short, s, phi_d, theta, beta, facet_kind, facet_data, log_table)
        log_long = _log_survival(log_short, n_short + 1, min(max(j_lo, j_hi), max_bounces), s, phi_d, theta, beta,
                                 facet_kind, facet_data, log_table)
    for p in range(2):
        j, width = pieces[p]
        if p == 1 and not split:
            break
        slot = slot_base + j % 2
        angle = _exit_angle(j, phi_d, theta, beta)
        ex = s * math.cos(angle)
        out[slot, FRACTION] = 0.5 * width
        out[slot, BOUNCES] = j
        out[slot, EXIT_X] = -ex if mirrored else ex
        out[slot, EXIT_Z] = s * math.sin(angle)
        out[slot, SURVIVAL] = _survival(log_short if j == j_short else log_long)
    return split


@njit(cache=True)
def groove_outcomes(out, tan_m, dx, dz, facet_kind, facet_data, log_table, unit_reflectance, max_bounces):
    """Every outcome of the paths entering one groove along ``(dx, ·, dz)``.

    Parameters
    ----------
    out : ndarray (N_SLOTS, N_FIELDS)
        Overwritten: per slot (:data:`N_SLOTS`) the share of the opening ``FRACTION``
        (0: no such outcome), ``BOUNCES``, the in-plane exit direction ``EXIT_X``,
        ``EXIT_Z`` (groove frame; the y' component is the incoming one) and
        ``SURVIVAL``, the product of the reflectances over ``min(n, max_bounces)`` hits.
        The fractions sum to 1.
    tan_m : float
        ``tan θ_m >= 0`` of the groove's walls.
    dx, dz : float
        In-plane components of the unit direction of travel ``d = -i`` in the groove
        frame, ``dz < 0``.
    facet_kind : int
        Registry position of the facet model (:mod:`vcavity.facet.registry`); its
        ``reflectance(cos, data)`` is the survival probability of one hit.
    facet_data : ndarray
        The facet's prepared data.
    log_table : ndarray
        :func:`log_reflectance_table` of the facet: ``log F`` by interpolation (empty: ``F``
        evaluated at every hit).
    unit_reflectance : bool
        True for mirrors (``F = 1``): the products are not evaluated.
    max_bounces : int
        The walk's bounce cap: a path of more bounces is truncated by the walk after
        ``max_bounces`` hits, so its survival covers those only.

    Returns
    -------
    int
        Regime bits (:data:`SPLIT_LEFT`, :data:`SPLIT_RIGHT`, :data:`VERTEX_INSIDE`): the
        places where the outcomes change form as the groove or the direction varies.
    """
    for slot in range(N_SLOTS):
        for field in range(N_FIELDS):
            out[slot, field] = 0.0
    s = math.sqrt(dx * dx + dz * dz)
    cx, cz = dx / s, dz / s
    # theta and beta = π - 2θ without cancellation in deep grooves (T up to ~1e300)
    theta = math.atan(tan_m)
    beta = 2.0 * math.atan(1.0 / tan_m) if tan_m > 0.0 else math.pi
    length = math.hypot(1.0, tan_m)
    regime = 0
    if _one_side(out, 0, False, cx, cz, s, tan_m, theta, beta, length, facet_kind, facet_data,
                 log_table, unit_reflectance, max_bounces):
        regime |= SPLIT_LEFT
    if _one_side(out, 2, True, -cx, cz, s, tan_m, theta, beta, length, facet_kind, facet_data,
                 log_table, unit_reflectance, max_bounces):
        regime |= SPLIT_RIGHT
    x_vertex = tan_m * cx / cz
    if -1.0 < x_vertex < 1.0:
        regime |= VERTEX_INSIDE
    return regime


__all__ = ["groove_outcomes", "log_reflectance_table", "N_SLOTS", "N_FIELDS", "FRACTION", "BOUNCES", "EXIT_X", "EXIT_Z", "SURVIVAL",
           "SPLIT_LEFT", "SPLIT_RIGHT", "VERTEX_INSIDE"]
