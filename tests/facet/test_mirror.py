"""The perfect mirror facet (vcavity/facet/mirror.py; physics.md sec. 4, limits): F = 1,
T = 0, no body, one variant, and an event that reflects and draws no random number."""

import math

import numpy as np
import pytest
from vcavity._numba.jit import njit  # caches where vcavity's own code does

from vcavity.facet import interfaced_lambertian as il
from vcavity.facet import mirror
from vcavity.facet.common import SCATTERED, reflect


def test_mirror_interface():
    assert mirror.NAME == "mirror" and il.NAME == "interfaced_lambertian"
    assert mirror.PARAMETERS == () and mirror.VARIANTS == ("mirror",)
    assert mirror.variant({}) == 0
    data = mirror.prepare({})
    assert data.dtype == np.float64 and data.shape == (0,)
    assert mirror.has_specular({}) and mirror.body_factor({}) == 0.0
    for c in np.linspace(0.0, 1.0, 11):
        assert mirror.reflectance(c, data) == 1.0  # albedo 1: nothing absorbed
        assert mirror.transmittance(c, data) == 0.0


@njit(cache=True)
def _mirror_events(n, dx, dy, dz, cos_in, nx, nz, data):
    state = np.uint64(7)
    out = np.empty((n, 3))
    outcomes = np.empty(n, np.int64)
    for k in range(n):
        state, outcomes[k], out[k, 0], out[k, 1], out[k, 2] = mirror.event(0, state, dx, dy, dz, cos_in, nx, nz, data)
    return state, outcomes, out


def test_mirror_event_reflects_without_drawing():
    rng = np.random.default_rng(4)
    for _ in range(50):
        tilt, psi, cos_in = rng.uniform(-1.4, 1.4), rng.uniform(0, 2 * math.pi), rng.uniform(1e-6, 1.0)
        nx, nz = math.sin(tilt), math.cos(tilt)
        s = math.sqrt(1.0 - cos_in * cos_in)
        dx = -cos_in * nx + s * math.cos(psi) * nz
        dy = s * math.sin(psi)
        dz = -cos_in * nz - s * math.cos(psi) * nx
        state, outcomes, out = _mirror_events(3, dx, dy, dz, cos_in, nx, nz, mirror.prepare({}))
        assert state == np.uint64(7)  # the stream is untouched
        assert np.all(outcomes == SCATTERED)
        rx, rz = reflect(dx, dz, cos_in, nx, nz)
        assert np.all(out == np.array([rx, dy, rz]))
        assert rx == dx + 2.0 * cos_in * nx and rz == dz + 2.0 * cos_in * nz
        # d' = d + 2 cos_in n: the reflected direction leaves with the same cosine
        assert rx * nx + rz * nz == pytest.approx(cos_in, rel=1e-12, abs=1e-15)

