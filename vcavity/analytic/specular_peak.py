"""The specular term over the sensor cells near the mirror direction, for lobes narrower
than a cell (physics.md sec. 6-7; docs/validation.md, "Narrow specular lobes").

A cell integral of the specular term, ``∫_c f_s cos θ_o dω_o``, is a Gauss-Legendre rule
in the cell's square coordinates (:mod:`vcavity.analytic.cells`) as long as the lobe is
resolved by the nodes. A lobe much narrower than a cell (Beckmann alpha 1e-4, Phong
exponent 1e300) falls between them and its whole mass is lost. Near its peak the integral
is therefore taken in the half-vector domain instead, through the distribution's own
sampling map ``(u1, u2) -> m`` of pdf ``D(m)(m.n)`` (W eq. 14 and 24):

    ∫_c f_s cos θ_o dω_o = ∫∫ F(i.m) G2(i, o, m) (i.m) / ((i.n)(m.n)) [o(m) in c] du1 du2,

``o(m) = 2 (i.m) m - i`` (``dω_o = 4 (i.m) dω_m``, W eq. 14; ``D dω_m = du1 du2 / (m.n)``).
No D is evaluated, so the integrand stays bounded (``<= 2 F`` for V-cavity masking) for
any roughness down to 1e-300. Each ray ``u2 = const`` (``m`` tilts away from ``n`` as
``u1`` grows) is cut where ``o`` crosses a cell edge, the horizon, or a kink of G2; those
points are found by bisection on the sensor's own binning (:func:`vcavity.sensor.binning.direction_to_cell`),
so the cell a piece belongs to is the cell the simulator counts it in. Each piece is a
Gauss-Legendre rule in ``τ`` with ``u1 = sin^2(π τ / 2)``, which removes the square-root
behaviour of ``m`` at both ends of ``u1``. (The walk, and why it cuts each step where the square
coordinates of ``o`` turn: :mod:`vcavity.analytic.peak_rays`.)

Per cell, the integrand over ``u2`` is smooth between the *events* of the rays: a ray
through a cell corner (a kink) and a ray tangent to a cell edge (beyond it the ray dips
into the next cell along a chord that grows as ``sqrt(u2 - u2_0)``). ``u2`` is split at
both (:func:`azimuth_breaks`, :func:`event_breaks`) and each piece gets a Gauss-Legendre
rule in ``t``, ``u2 = lo + (hi - lo) sin^2(π t / 2)``, smooth at a square-root end. Split
at the corners alone (before 2026-12), a tangency 4e-4 of ``u2`` short of a corner ray
fell between the last node of every rule and the piece's end: on the 9 x 9 sensor, GGX
alpha 0.376 at ``cos θ_i = 9/31``, ``φ_i = 0``, two cells were 3e-5 too high with an
error estimate of 1e-15 (docs/validation.md).

Only the cells of the peak region (:func:`vcavity.analytic.peak_cells.peak_cells`: the 3 x 3 cells around the mirror
direction, and for an anisotropic lobe the cells its thin ridge crosses) are integrated this
way; beyond it the lobe varies on the scale of its distance from the peak, and the
sub-cell rule resolves it.
"""

from __future__ import annotations

import math

import numpy as np

from vcavity.analytic.peak_cells import corner_u2
from vcavity.analytic.peak_rays import _rays, _signatures
from vcavity.analytic.quadrature import subcell_quadrature
from vcavity.sensor.binning import square_to_hemisphere
from vcavity.sensor.grid import square_to_hemisphere_array

_HALF_PI = 0.5 * math.pi
#: Gauss-Legendre nodes per u2 piece and per tau piece (accuracy controls; the error is
#: estimated by halving them, :mod:`vcavity.analytic.exact_f1`).
DEFAULT_AZIMUTH_NODES = 8
DEFAULT_RADIAL_NODES = 8
#: Default absolute accuracy per cell of the azimuthal rule of the peak rays, and the most
#: halvings of a u2 piece.
DEFAULT_PEAK_TOLERANCE = 1e-10
MAX_DEPTH = 24
MAX_PIECES = 4096
#: Rays of the scan for the events of :func:`event_breaks`, bisection steps per event
#: (to ``2^-32 / EVENT_SCAN`` in ``u2``) and rounds of looking between two found events.
EVENT_SCAN = 256
EVENT_BISECTIONS = 32
MAX_EVENT_ROUNDS = 8
#: How far inside an interval between corner rays its end rays are scanned (relative).
EVENT_END = 1e-9


def _corners(cells, n):
    """Square coordinates of the distinct corners of ``cells``."""
    ix, iy = cells % n, cells // n
    corners = set()
    for dx in (0, 1):
        for dy in (0, 1):
            corners.update(zip((ix + dx).tolist(), (iy + dy).tolist()))
    k = np.array(sorted(corners), dtype=np.float64).reshape(-1, 2)
    return -1.0 + 2.0 * k[:, 0] / n, -1.0 + 2.0 * k[:, 1] / n


def azimuth_breaks(model, incident, sensor, cells) -> np.ndarray:
    """Sorted ``u2`` of the rays through the corners of ``cells`` (plus 0), in [0, 1)."""
    u, v = _corners(cells, sensor.resolution)
    breaks = [0.0]
    for uk, vk in zip(u, v):
        ox, oy, oz = square_to_hemisphere(float(uk), float(vk))
        hx, hy = incident[0] + ox, incident[1] + oy
        value = corner_u2(hx, hy, model.kind, model.params, 256)
        if value >= 0.0:
            breaks.append(value)
    breaks = np.unique(np.asarray(breaks))
    return breaks


def event_breaks(model, incident, sensor, cells, corners=None, n_scan=EVENT_SCAN, should_stop=None) -> np.ndarray:
    """Sorted ``u2`` in [0, 1) of the tangency events of the rays, and any other change of
    a ray's transitions into and out of the peak cells (the hash of
    :func:`vcavity.analytic.peak_rays._walk`) between two rays through cell corners.

    Between two events every peak cell's integral is a smooth function of ``u2``; at one
    it is not: a ray through a cell corner (a kink; ``corners``, default
    :func:`azimuth_breaks`) and a ray tangent to a cell edge (a square-root change: beyond
    it the ray dips into the next cell along a chord that grows as ``sqrt(u2 - u2_0)``).
    Each interval between corner rays is scanned (its two ends, ``EVENT_END`` of its width
    inside, and the rays of an ``n_scan`` grid within it, never across a corner, so that
    a tangency next to a corner ray cannot hide behind it); between two rays whose hashes
    differ the event is bisected from both sides (the end of the left ray's transitions
    and the start of the right one's; what lies between is looked at again). A
    dip that appears and disappears between two scan rays is missed: two tangencies of
    one smooth fold less than ``1/n_scan`` apart, whose sliver is ``O(w^3)``, negligible.
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    cells = np.asarray(cells, dtype=np.int64)
    slot_of_cell = np.full(sensor.n_cells, -1, dtype=np.int64)
    slot_of_cell[cells] = np.arange(cells.size)
    tan_stop = _tan_stop(incident, sensor, cells)
    gl_x, gl_w = np.polynomial.legendre.leggauss(2)  # unused by the walk when it does not integrate

    def sign(u2):
        return _signatures(np.ascontiguousarray(np.asarray(u2, dtype=np.float64) % 1.0), incident, model.kind,
                           model.params, model.facet_kind, model.facet_data, model.masking_code,
                           model.lambda_fit, sensor.resolution, slot_of_cell, tan_stop, gl_x, gl_w, should_stop)

    corners = azimuth_breaks(model, incident, sensor, cells) if corners is None else np.asarray(corners)
    ends = np.append(corners, corners[0] + 1.0)
    grid = (np.arange(n_scan) + 0.5) / n_scan
    a_list, b_list = [], []
    for lo, hi in zip(ends[:-1], ends[1:]):
        if hi - lo <= 1e-15:
            continue
        inside = grid[(grid > lo) & (grid < hi)] if hi <= 1.0 else np.concatenate(
            [grid[grid > lo], grid[grid < hi - 1.0] + 1.0])
        points = np.concatenate([[lo + EVENT_END * (hi - lo)], inside, [hi - EVENT_END * (hi - lo)]])
        a_list.append(points[:-1])
        b_list.append(points[1:])
    a, b = np.concatenate(a_list), np.concatenate(b_list)
    signature = sign(np.concatenate([a, b]))
    sa, sb = signature[:a.size], signature[a.size:]
    differ = sa != sb
    a, b, sa, sb = a[differ], b[differ], sa[differ], sb[differ]
    breaks = []
    for _ in range(MAX_EVENT_ROUNDS):
        if a.size == 0:
            break
        # bisect both ends at once: [lo, hi] brackets the end of the left state, [lo2, hi2] the start of the right
        lo, hi, lo2, hi2 = a.copy(), b.copy(), a.copy(), b.copy()
        for _ in range(EVENT_BISECTIONS):
            mid, mid2 = 0.5 * (lo + hi), 0.5 * (lo2 + hi2)
            s = sign(np.concatenate([mid, mid2]))
            left, right = s[:mid.size] == sa, s[mid.size:] == sb
            lo, hi = np.where(left, mid, lo), np.where(left, hi, mid)
            lo2, hi2 = np.where(right, lo2, mid2), np.where(right, mid2, hi2)
        breaks.extend((0.5 * (lo + hi)).tolist())
        breaks.extend((0.5 * (lo2 + hi2)).tolist())
        gap = hi < lo2  # states other than the two ends lie between them: look there
        a, b = hi[gap], lo2[gap]
        s = sign(np.concatenate([a, b])) if a.size else np.zeros(0, dtype=np.int64)
        sa, sb = s[:a.size], s[a.size:]
        differ = sa != sb
        a, b, sa, sb = a[differ], b[differ], sa[differ], sb[differ]
    return np.unique(np.asarray(breaks, dtype=np.float64) % 1.0)


def peak_integrals(model, incident, sensor, cells, n_azimuth=DEFAULT_AZIMUTH_NODES,
                   n_radial=DEFAULT_RADIAL_NODES, tolerance=DEFAULT_PEAK_TOLERANCE, with_error=False, should_stop=None):
    """``∫_c f_s cos θ_o dω_o`` for each of ``cells`` by rays in the half-vector domain.

    ``u2`` is split at the rays through the cells' corners (:func:`azimuth_breaks`);
    each piece gets an ``n_azimuth``-point Gauss-Legendre rule and is halved until the
    halves agree with the whole within ``tolerance`` times the piece's width in every
    cell (the sum of the accepted differences, at most ``tolerance`` per cell unless
    :data:`MAX_DEPTH` halvings or :data:`MAX_PIECES` pieces were not enough, is the
    azimuthal error estimate). The
    radial error is the change when ``n_radial`` is halved.

    Parameters
    ----------
    model : vcavity.analytic.SingleBounceModel
        Its distribution, facet and masking.
    incident : array_like (3,)
        Unit direction toward the light.
    sensor : EqualAreaSensor
    cells : array_like of int
        The cells (usually :func:`peak_cells`); every ray is followed until it is beyond
        all of them.
    n_azimuth, n_radial : int
        Gauss-Legendre nodes per ``u2`` piece and per ``tau`` piece.
    tolerance : float
        Absolute accuracy per cell of the azimuthal rule.
    with_error : bool
        Also return the error estimate per cell.
    should_stop : callable, optional
        Polled between the compiled calls (batches of rays, :mod:`vcavity.analytic.batches`).

    Returns
    -------
    integrals : ndarray (len(cells),)
        Cosine-weighted integrals (dimensionless), in the order of ``cells``.
    error : ndarray (len(cells),)
        Only with ``with_error``: azimuthal plus radial error estimate (conservative:
        differences between a rule and its refinement).
    """
    incident = np.ascontiguousarray(incident, dtype=np.float64).reshape(3)
    cells = np.asarray(cells, dtype=np.int64)
    if not model.has_specular or cells.size == 0 or incident[2] <= 0.0:
        zeros = np.zeros(cells.size)
        return (zeros, zeros.copy()) if with_error else zeros
    slot_of_cell = np.full(sensor.n_cells, -1, dtype=np.int64)
    slot_of_cell[cells] = np.arange(cells.size)
    tan_stop = _tan_stop(incident, sensor, cells)
    x, w = np.polynomial.legendre.leggauss(int(n_azimuth))

    def pieces(lo, hi, n_radial):
        """Integral over each piece [lo_k, hi_k] of u2, shape (pieces, cells): Gauss-Legendre
        in ``t`` with ``u2 = lo + (hi - lo) sin^2(π t / 2)``, which makes the square-root
        change at a tangency event (:func:`event_breaks`) at either end of a piece smooth."""
        t = 0.5 * (x + 1.0)
        width = (hi - lo)[:, None]
        nodes = (lo[:, None] + width * np.sin(_HALF_PI * t)[None, :] ** 2) % 1.0
        weights = width * (0.5 * w * _HALF_PI * np.sin(math.pi * t))[None, :]
        gl_x, gl_w = np.polynomial.legendre.leggauss(int(n_radial))
        per_node = _rays(np.ascontiguousarray(nodes.ravel()), np.ascontiguousarray(weights.ravel()), incident,
                         model.kind, model.params, model.facet_kind, model.facet_data, model.masking_code,
                         model.lambda_fit, sensor.resolution, slot_of_cell, cells.size, tan_stop, gl_x, gl_w,
                         should_stop)
        return per_node.reshape(lo.size, x.size, cells.size).sum(axis=1)

    corners = azimuth_breaks(model, incident, sensor, cells)
    breaks = np.union1d(corners, event_breaks(model, incident, sensor, cells, corners, should_stop=should_stop))
    ends = np.append(breaks, breaks[0] + 1.0)
    lo, hi = ends[:-1], ends[1:]
    keep = hi - lo > 1e-15
    lo, hi = lo[keep], hi[keep]
    whole = pieces(lo, hi, n_radial)
    total = np.zeros(cells.size)
    error = np.zeros(cells.size)
    accepted = []
    for depth in range(MAX_DEPTH + 1):
        mid = 0.5 * (lo + hi)
        halves = pieces(np.concatenate([lo, mid]), np.concatenate([mid, hi]), n_radial)
        refined = halves[:lo.size] + halves[lo.size:]
        difference = np.abs(refined - whole)
        done = np.all(difference <= tolerance * (hi - lo)[:, None], axis=1)
        if depth == MAX_DEPTH or 2 * np.count_nonzero(~done) > MAX_PIECES:  # bounded cost
            done[:] = True
        total += refined[done].sum(axis=0)
        error += difference[done].sum(axis=0)
        accepted.append((lo[done], hi[done]))
        if np.all(done):
            break
        lo, hi = np.concatenate([lo[~done], mid[~done]]), np.concatenate([mid[~done], hi[~done]])
        whole = np.concatenate([halves[:mid.size][~done], halves[mid.size:][~done]])
    if not with_error:
        return total
    if int(n_radial) >= 2:
        # radial error: the same pieces with half the tau nodes
        lo_all = np.concatenate([a for a, _ in accepted])
        hi_all = np.concatenate([b for _, b in accepted])
        mid = 0.5 * (lo_all + hi_all)
        coarse = pieces(np.concatenate([lo_all, mid]), np.concatenate([mid, hi_all]), max(int(n_radial) // 2, 1))
        error += np.abs(coarse.sum(axis=0) - total)
    return total, error


def _tan_stop(incident, sensor, cells):
    """1.5 x the largest ``tan θ_h`` at the nodes and corners of ``cells``: beyond it a ray
    (``tan θ_m`` grows along it) reaches none of them."""
    directions, _ = subcell_quadrature(sensor, 4, cells=cells)
    u, v = _corners(cells, sensor.resolution)
    points = np.concatenate([directions.reshape(-1, 3), square_to_hemisphere_array(u, v)])
    h = points + incident[None, :]
    tan_h = np.hypot(h[:, 0], h[:, 1]) / np.maximum(h[:, 2], 1e-300)
    return 1.5 * float(np.max(tan_h)) + 1e-300


__all__ = ["peak_integrals", "azimuth_breaks", "DEFAULT_AZIMUTH_NODES", "DEFAULT_RADIAL_NODES"]
