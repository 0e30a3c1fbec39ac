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


@njit(cache=True)
def _survival(n, s, phi_d, theta, beta, facet_kind, facet_data, unit_reflectance, max_bounces):
    """Product of ``F(s |sin(φ_d - a_b)|)`` over the first ``min(n, max_bounces)`` spokes.

    A product below :data:`NEGLIGIBLE_SURVIVAL` is returned as 0: what is left of such a
    path is below any table's resolution, and deep grooves (thousands of hits) would
    otherwise cost a reflectance per hit.
    """
    if unit_reflectance:
        return 1.0
    product = 1.0
    for b in range(1, min(n, max_bounces) + 1):
        cos_hit = s * abs(math.sin(phi_d - (theta + b * beta)))
        product *= facets.reflectance(facet_kind, min(cos_hit, 1.0), facet_data)
        if product < NEGLIGIBLE_SURVIVAL:
            return 0.0
    return product


@njit(cache=True)
def _one_side(out, slot_base, mirrored, cx, cz, s, tan_m, theta, beta, length, facet_kind, facet_data,
              unit_reflectance, max_bounces):
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
        out[slot, SURVIVAL] = _survival(j, s, phi_d, theta, beta, facet_kind, facet_data, unit_reflectance,
                                        max_bounces)
    return split


@njit(cache=True)
def groove_outcomes(out, tan_m, dx, dz, facet_kind, facet_data, unit_reflectance, max_bounces):
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
                 unit_reflectance, max_bounces):
        regime |= SPLIT_LEFT
    if _one_side(out, 2, True, -cx, cz, s, tan_m, theta, beta, length, facet_kind, facet_data,
                 unit_reflectance, max_bounces):
        regime |= SPLIT_RIGHT
    x_vertex = tan_m * cx / cz
    if -1.0 < x_vertex < 1.0:
        regime |= VERTEX_INSIDE
    return regime


__all__ = ["groove_outcomes", "N_SLOTS", "N_FIELDS", "FRACTION", "BOUNCES", "EXIT_X", "EXIT_Z", "SURVIVAL",
           "SPLIT_LEFT", "SPLIT_RIGHT", "VERTEX_INSIDE"]
