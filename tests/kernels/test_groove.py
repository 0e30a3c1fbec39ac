"""The groove tracer against a plain Cartesian ray/segment reference (physics.md sec. 5)."""

import numpy as np
import pytest

from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, RIGHT, enter, leave, next_surface


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


# ------------------------------------------- the kernel's specialised segments (enter, leave)

def _random_start(rng, tan_m):
    """A boundary point and a direction going into the air region from it."""
    while True:
        surface = int(rng.integers(0, 3))
        x = rng.uniform(-1, 1) if surface == OPENING else (rng.uniform(-1, 0) if surface == LEFT else rng.uniform(0, 1))
        angle = rng.uniform(0, 2 * np.pi)
        dx, dz = np.cos(angle), np.sin(angle)
        c = 1.0 / np.sqrt(1.0 + tan_m * tan_m) if tan_m < 1e150 else 1.0 / tan_m
        s = tan_m * c if tan_m < 1e150 else 1.0
        into = {OPENING: -dz, LEFT: s * dx + c * dz, RIGHT: -s * dx + c * dz}[surface]
        if into > 1e-12:
            return surface, x, dx, dz


@pytest.mark.parametrize("tan_m", [1e-8, 0.01, 0.3, 1.0, 4.0, 1e4, 1e8, 1e300])
def test_enter_and_leave_are_next_surface(tan_m):
    """Same wall and bit-identical hit point as the general tracer (ties have probability 0)."""
    rng = np.random.default_rng(int(np.log10(tan_m)) + 100)
    for _ in range(4000):
        surface, x, dx, dz = _random_start(rng, tan_m)
        want = next_surface(surface, x, dx, dz, tan_m)
        got = enter(x, dx, dz, tan_m) if surface == OPENING else leave(surface, x, dx, dz, tan_m)
        assert got == want, (surface, x, dx, dz, tan_m)


@pytest.mark.parametrize("tan_m", [1e-4, 0.3, 1.0, 1e4])
@pytest.mark.parametrize("theta_deg", [30.0, 89.99])
def test_mirror_walk_with_enter_and_leave_follows_next_surface(tan_m, theta_deg):
    rng = np.random.default_rng(3)
    cos_t = 1.0 / np.sqrt(1.0 + tan_m * tan_m)
    sin_t = tan_m * cos_t
    for _ in range(200):
        phi = rng.uniform(0.0, 2.0 * np.pi)
        dx, dz = -np.sin(np.radians(theta_deg)) * np.cos(phi), -np.cos(np.radians(theta_deg))
        x = rng.uniform(-1.0, 1.0)
        surface, x_fast = enter(x, dx, dz, tan_m)
        assert (surface, x_fast) == next_surface(OPENING, x, dx, dz, tan_m)
        x = x_fast
        for _ in range(100):
            side = 1.0 if surface == LEFT else -1.0
            cos_in = -(dz + side * (tan_m * dx)) * cos_t
            dx, dz = dx + 2.0 * cos_in * side * sin_t, dz + 2.0 * cos_in * cos_t
            fast = leave(surface, x, dx, dz, tan_m)
            assert fast == next_surface(surface, x, dx, dz, tan_m)
            surface, x = fast
            if surface in (OPENING, NO_HIT):
                break
        assert surface == OPENING or (tan_m > 1.0 and surface != NO_HIT)  # deep grooves: ~tan_m bounces


def test_enter_refuses_a_ray_along_the_opening():
    assert enter(0.5, 1.0, 0.0, 0.0)[0] == NO_HIT
    assert enter(0.5, 0.0, 0.0, 2.0)[0] == NO_HIT
