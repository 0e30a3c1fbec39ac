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

from vcavity._jit import njit

OPENING = 0
LEFT = 1
RIGHT = 2
#: Returned when no boundary is ahead (only through rounding in degenerate
#: configurations); the kernel counts such paths instead of raising.
NO_HIT = -1


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
