"""Exact geometry of one symmetric V-groove (physics.md sec. 5; IL sec. 3.3, H sec. 4.2).

The groove's cross-section lives in the x'z plane of the groove frame
(x' = (cos phi_m, sin phi_m, 0), y' = groove axis, z = macro normal):

- the opening ``O``: z = 0, x' in [-1, 1];
- the left facet ``L`` from (-1, 0) to the vertex (0, -T), normal (sin t, 0, cos t);
- the right facet ``R`` from (1, 0) to the vertex, normal (-sin t, 0, cos t);

with ``T = tan(theta_m)``. The air region is the triangle between them. A point on the
boundary is stored as (surface, x): its depth follows from the surface's line, so a
segment never starts "slightly off" its surface and no epsilon is needed. Heights
above the facet lines are written in closed form per surface, which avoids the
cancellation of ``z + T (1 + x)`` in deep grooves (T up to ~1e8 for GGX).

Distances along a direction ``(dx, dz)`` are compared in the scaled form
``height / rate`` where ``rate`` is the derivative of that height along the ray; a
boundary is a candidate only if the ray approaches it (rate < 0) and the ray does not
start on it.
"""

from __future__ import annotations

import numpy as np

from vcavity._numba.jit import njit

OPENING = 0
LEFT = 1
RIGHT = 2
#: Returned when no boundary is ahead (only through rounding in degenerate
#: configurations); the kernel counts such paths instead of raising.
NO_HIT = -1


# The walk's two segment kinds, specialised (physics.md sec. 5). The triangle is convex, so
# where a straight segment leaves it follows from one sign test instead of comparing the
# distances to every candidate line (one division per segment instead of two or three),
# and the side of the hit wall is selected without a branch: left and right are equally
# likely, so a branch mispredicts half the time. Every product stays below 2e300 for
# tan_m <= MAX_TAN_THETA = 1e300 (no overflow). The hit point is computed with exactly
# the expressions of next_surface, and ties (a segment through the vertex or a corner)
# are resolved as next_surface resolves them. Plain functions (not IR-inlined): LLVM
# inlines them all the same, and IR inlining costs compile time per call site.


@njit(cache=True)
def enter(x, dx, dz, tan_m):
    """The first segment: from the opening point ``x`` down to a wall.

    Equivalent to ``next_surface(OPENING, x, dx, dz, tan_m)``: a ray entering the groove
    (``dz < 0``) reaches the vertex depth ``z = -T`` at ``x + dx T / (-dz)``, and leaves
    the triangle through the left wall when that point is left of the vertex (or on it).

    Returns
    -------
    (surface, x) : (int, float)
        ``LEFT`` or ``RIGHT`` and the hit point's x' (clamped onto the wall), or
        ``(NO_HIT, x)`` for a ray that does not enter (``dz >= 0``, never in a run).
    """
    left = x * dz - dx * tan_m >= 0.0
    side = 1.0 if left else -1.0  # the hit wall's normal is (side sin t, 0, cos t)
    rate = dz + side * (tan_m * dx)  # d(height above the hit wall's line)/ds, < 0
    if not rate < 0.0:
        return NO_HIT, x
    x_hit = x + (tan_m * (1.0 + side * x) / -rate) * dx
    lo = -1.0 if left else 0.0
    hi = 0.0 if left else 1.0
    return (LEFT if left else RIGHT), min(max(x_hit, lo), hi)


@njit(cache=True)
def leave(surface, x, dx, dz, tan_m):
    """A segment from a wall: to the other wall or out through the opening.

    Equivalent to ``next_surface(surface, x, dx, dz, tan_m)`` for ``surface`` ``LEFT`` or
    ``RIGHT``. Written for the left wall (``side = 1``; the right one is its mirror image
    ``x -> -x``): a ray going up (``dz > 0``) crosses ``z = 0`` at
    ``x + dx T (1 + x) / dz``, which is on the opening exactly when it is left of the
    right corner ``x' = 1``; otherwise it meets the right wall if it approaches it.

    Returns
    -------
    (surface, x) : (int, float)
        ``OPENING`` or the other wall and the hit point's x' (clamped), or ``(NO_HIT, x)``
        when rounding left no boundary ahead.
    """
    left = surface == LEFT
    side = 1.0 if left else -1.0
    sx = side * x  # in [-1, 0] on either wall
    tdx = tan_m * dx
    rate = dz - side * tdx  # approach rate to the other wall's line
    # strict: a segment through the far corner is a wall hit, as in next_surface; a rising
    # ray that does not approach the other wall (a tie at the vertex) can only leave
    if dz > 0.0 and (side * tdx * (1.0 + sx) < dz * (1.0 - sx) or not rate < 0.0):
        return OPENING, min(max(x + (tan_m * (1.0 + sx) / dz) * dx, -1.0), 1.0)
    if rate < 0.0:
        x_hit = x + (-2.0 * side * tan_m * x / -rate) * dx
        lo = 0.0 if left else -1.0
        hi = 1.0 if left else 0.0
        return (RIGHT if left else LEFT), min(max(x_hit, lo), hi)
    return NO_HIT, x


@njit(cache=True, inline="always")
def next_surface(surface, x, dx, dz, tan_m):
    """Trace one straight segment inside the groove.

    Parameters
    ----------
    surface : int
        Where the segment starts: ``OPENING``, ``LEFT`` or ``RIGHT``.
    x : float
        The start point's x' coordinate (in [-1, 1] on the opening, [-1, 0] on the left
        facet, [0, 1] on the right facet).
    dx, dz : float
        The direction's x' and z components (the y' component does not affect the
        cross-section; the direction need not be normalised).
    tan_m : float
        tan(theta_m) >= 0, the groove depth.

    Returns
    -------
    (surface, x) : (int, float)
        The surface hit next and the x' coordinate of the hit point (clamped onto the
        hit facet's extent), or ``(NO_HIT, x)``.
    """
    # heights above the left line (z + T(1+x)), the right line (z + T(1-x)) and depth
    # below the opening (-z), in closed form for each starting surface.
    if surface == OPENING:
        h_left = tan_m * (1.0 + x)
        h_right = tan_m * (1.0 - x)
        depth = 0.0
    elif surface == LEFT:
        h_left = 0.0
        h_right = -2.0 * tan_m * x
        depth = tan_m * (1.0 + x)
    else:
        h_left = 2.0 * tan_m * x
        h_right = 0.0
        depth = tan_m * (1.0 - x)

    best = np.inf
    hit = NO_HIT
    rate_left = dz + tan_m * dx  # d(h_left)/ds
    if surface != LEFT and rate_left < 0.0:
        s = h_left / -rate_left
        if s < best:
            best = s
            hit = LEFT
    rate_right = dz - tan_m * dx  # d(h_right)/ds
    if surface != RIGHT and rate_right < 0.0:
        s = h_right / -rate_right
        if s < best:
            best = s
            hit = RIGHT
    if surface != OPENING and dz > 0.0:
        s = depth / dz
        if s < best:
            best = s
            hit = OPENING
    if hit == LEFT:
        x = min(max(x + best * dx, -1.0), 0.0)
    elif hit == RIGHT:
        x = min(max(x + best * dx, 0.0), 1.0)
    elif hit == OPENING:
        x = min(max(x + best * dx, -1.0), 1.0)
    return hit, x
