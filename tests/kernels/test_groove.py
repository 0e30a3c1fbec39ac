"""The groove tracer against a plain Cartesian ray/segment reference (physics.md sec. 5)."""

import numpy as np
import pytest

from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, RIGHT, next_surface


def _point(surface, x, tan_m):
    """Cartesian (x', z) of a boundary point stored as (surface, x)."""
    if surface == OPENING:
        return np.array([x, 0.0])
    if surface == LEFT:
        return np.array([x, -tan_m * (1.0 + x)])
    return np.array([x, -tan_m * (1.0 - x)])


def _reference(surface, x, d, tan_m):
    """Nearest segment hit by brute force: solve p + s d = a + t (b - a) for each segment."""
    p = _point(surface, x, tan_m)
    vertex = np.array([0.0, -tan_m])
    segments = {OPENING: (np.array([-1.0, 0.0]), np.array([1.0, 0.0])),
                LEFT: (np.array([-1.0, 0.0]), vertex),
                RIGHT: (np.array([1.0, 0.0]), vertex)}
    best, hit = np.inf, NO_HIT
    for name, (a, b) in segments.items():
        if name == surface:
            continue
        m = np.array([[d[0], a[0] - b[0]], [d[1], a[1] - b[1]]])
        if abs(np.linalg.det(m)) < 1e-300:
            continue
        s, t = np.linalg.solve(m, a - p)
        if s >= 0 and -1e-9 <= t <= 1 + 1e-9 and s < best:
            best, hit = s, name
    return hit, (p + best * d)[0] if hit != NO_HIT else x


@pytest.mark.parametrize("tan_m", [0.01, 0.3, 1.0, 4.0, 50.0])
def test_matches_cartesian_reference(tan_m):
    rng = np.random.default_rng(12345)
    checked = 0
    for _ in range(3000):
        surface = int(rng.integers(0, 3))
        x = rng.uniform(-1, 1) if surface == OPENING else (rng.uniform(-1, 0) if surface == LEFT else rng.uniform(0, 1))
        angle = rng.uniform(0, 2 * np.pi)
        d = np.array([np.cos(angle), np.sin(angle)])
        # only directions that go into the air region from the start surface
        normal = {OPENING: np.array([0.0, -1.0]),
                  LEFT: np.array([tan_m, 1.0]) / np.hypot(tan_m, 1.0),
                  RIGHT: np.array([-tan_m, 1.0]) / np.hypot(tan_m, 1.0)}[surface]
        if d @ normal <= 1e-6:
            continue
        hit, x_hit = next_surface(surface, x, d[0], d[1], tan_m)
        ref_hit, ref_x = _reference(surface, x, d, tan_m)
        assert hit == ref_hit, (surface, x, d, tan_m)
        assert abs(x_hit - ref_x) < 1e-9 * max(1.0, tan_m)
        checked += 1
    assert checked > 1000


def test_hit_points_stay_on_the_hit_facet():
    rng = np.random.default_rng(7)
    for tan_m in (1e-8, 1e-3, 1.0, 1e4, 1e8):
        for _ in range(500):
            x0 = rng.uniform(-1, 1)
            angle = rng.uniform(np.pi, 2 * np.pi)  # downward from the opening
            hit, x = next_surface(OPENING, x0, np.cos(angle), np.sin(angle), tan_m)
            assert hit in (LEFT, RIGHT)
            assert (-1.0 <= x <= 0.0) if hit == LEFT else (0.0 <= x <= 1.0)


def test_direction_along_opening_from_opening_has_no_hit_only_when_parallel():
    # a ray leaving the opening horizontally into a flat groove (tan = 0) never enters it
    hit, _ = next_surface(OPENING, 0.5, 1.0, 0.0, 0.0)
    assert hit == NO_HIT
