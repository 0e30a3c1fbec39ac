"""The kernel's disk-point groove sampler is the same map as each distribution's sample."""

import math

import numpy as np
import pytest

from vcavity.kernels.sampling import groove_from_disk
from vcavity.microfacet import DISTRIBUTIONS

CASES = [
    ("beckmann", (0.6, 0.6)), ("beckmann", (0.05, 0.9)), ("ggx", (0.3, 0.3)), ("ggx", (2.0, 0.01)),
    ("phong", (20.0,)), ("phong", (0.0,)), ("gaussian", (0.35,)),
]


@pytest.mark.parametrize("name, args", CASES)
def test_same_map_as_sample(name, args):
    module = DISTRIBUTIONS[name]
    params = module.make_params(*args)
    rng = np.random.default_rng(99)
    # u1 >= 0.5 so that s = 1 - u1 is exact (Sterbenz); plus the lower half separately
    for u1, u2 in zip(np.concatenate([rng.uniform(0.5, 1.0, 2000), rng.uniform(1e-9, 0.5, 2000)]),
                      rng.uniform(0.0, 1.0, 4000)):
        s = 1.0 - u1
        a, b = math.sqrt(s) * math.cos(2 * math.pi * u2), math.sqrt(s) * math.sin(2 * math.pi * u2)
        t_ref, c_ref, s_ref = module.sample(u1, u2, params)
        t, c, sn = groove_from_disk(module.KIND, a, b, a * a + b * b, params)
        assert t == pytest.approx(t_ref, rel=1e-9, abs=1e-12)
        if t_ref > 1e-12:
            assert c == pytest.approx(c_ref, abs=1e-9)
            assert sn == pytest.approx(s_ref, abs=1e-9)
        assert abs(math.hypot(c, sn) - 1.0) < 1e-14


@pytest.mark.parametrize("name, args", CASES)
def test_extreme_disk_points_are_finite(name, args):
    module = DISTRIBUTIONS[name]
    params = module.make_params(*args)
    # the kernel's disk points are 2u - 1 with 53-bit u: |a|, |b| are 0 or >= 2^-52, and
    # the centre (s = 0) and the rim (s >= 1) are rejected
    tiny, edge = 2.0**-52, 1.0 - 2.0**-52
    for a, b in [(tiny, 0.0), (0.0, -tiny), (tiny, tiny), (edge, 0.0), (0.0, -edge),
                 (0.7071067811865475, 0.7071067811865475)]:
        s = a * a + b * b
        if not 0.0 < s < 1.0:
            continue
        t, c, sn = groove_from_disk(module.KIND, a, b, s, params)
        assert math.isfinite(t) and t >= 0.0
        assert abs(math.hypot(c, sn) - 1.0) < 1e-12
