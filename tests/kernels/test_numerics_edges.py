"""Numerics at the edges: sampling at the ends of [0, 1) and of the parameter
ranges, Fresnel / r_e / r_i through eta -> 1 and at huge eta, the groove geometry at
grazing light against exact rational arithmetic, binning at the pole, and float64
throughout the walk. Deterministic checks (no false-positive rate).
"""

import decimal
import itertools
import math
from fractions import Fraction

import numba
import numpy as np
import pytest

from vcavity.config import validate
from vcavity.facet import fresnel as fr
from vcavity.kernels.groove import LEFT, NO_HIT, OPENING, RIGHT, next_surface
from vcavity.microfacet import beckmann, ggx
from vcavity.microfacet import registry as distributions
from vcavity.microfacet.common import MAX_TAN_THETA, normal_from_slope_angle, stretched_slope
from vcavity.kernels import loop
from vcavity.parameters import Roughness
from vcavity.sensor.binning import bin_block, direction_to_cell
from vcavity.simulate.pipeline import Simulation, simulate

U_ENDS = [0.0, 2.0**-53, 1e-300, 0.25, 0.5, 0.75, 1.0 - 2.0**-52, 1.0 - 2.0**-53]
# Every positive float is a valid roughness (alpha_x along +x, alpha_y along +y)
ROUGHNESS_X = (5e-324, 1e-300, 1e-170, 1e-4, 1.0, 10.0, 1e150, 1e200, 1.7e308)
ROUGHNESS_Y = (1e-300, 1e-3, 1.0, 1e300)
# candidates for a scalar parameter, kept where its declared range accepts them
SCALAR_CANDIDATES = (1e-300, 1e-160, 1e-100, 1e-4, 1.0, 2.0, 10.0, 1e3, 2e8, 1e300)
MAX_SETS = 120


def _params(name, *args):
    """Parameter array from canonical values in key order (alpha_x, alpha_y / exponent / sigma)."""
    return distributions.get(name).params_from(dict(zip(distributions.value_keys(name), args)))


def _scalar_edges(spec):
    """A scalar parameter at the ends of its declared range (the open ends' nearest floats)
    and at the candidates inside it, plus its documented example."""
    lo = -1.7e308 if spec.lo is None else (math.nextafter(spec.lo, math.inf) if spec.lo_open else spec.lo)
    hi = 1.7e308 if spec.hi is None else (math.nextafter(spec.hi, -math.inf) if spec.hi_open else spec.hi)
    values = {lo, hi, spec.example, *(x for x in SCALAR_CANDIDATES if lo <= x <= hi)}
    return [{spec.key: x} for x in sorted(v for v in values if abs(v) < 1.7e308 or v in (lo, hi))]


def edge_parameter_sets(name):
    """Canonical values of ``name`` at the edges of every declared parameter range, from the
    registry's declarations (no table per distribution): the product over the parameters,
    thinned evenly to at most MAX_SETS sets."""
    per_spec = []
    for spec in distributions.get(name).PARAMETERS:
        if isinstance(spec, Roughness):
            per_spec.append([{"alpha_x": a, "alpha_y": b} for a in ROUGHNESS_X for b in ROUGHNESS_Y])
        else:
            per_spec.append(_scalar_edges(spec))
    sets = [dict(kv for part in combo for kv in part.items()) for combo in itertools.product(*per_spec)]
    return sets[::math.ceil(len(sets) / MAX_SETS)]


@pytest.mark.parametrize("name", distributions.NAMES)
def test_sampled_normals_unit_and_upper_at_the_ends(name):
    module = distributions.get(name)
    for values in edge_parameter_sets(name):
        params = module.params_from(values)
        for u1 in U_ENDS:
            for u2 in U_ENDS:
                t, c, s = module.sample(u1, u2, params)
                assert math.isfinite(t) and 0.0 <= t <= MAX_TAN_THETA, (values, u1, u2)
                assert abs(math.hypot(c, s) - 1.0) <= 4e-16
                mx, my, mz = module.sample_normal(u1, u2, params)
                assert mz > 0.0 and abs(math.sqrt(mx * mx + my * my + mz * mz) - 1.0) <= 4e-16


def test_steepest_ggx_groove_and_huge_tangents():
    # u1 = 1 - 2^-53: r = sqrt(u1/(1 - u1)) ~ 2^26.5; the tangent is finite and the normal unit
    t, _, _ = ggx.sample(1.0 - 2.0**-53, 0.3, _params("ggx", 10.0, 10.0))
    assert t == pytest.approx(10.0 * math.sqrt((1.0 - 2.0**-53) * 2.0**53), rel=1e-15)
    for big in (1e150, 1e200, 1e300, MAX_TAN_THETA):
        mx, _, mz = normal_from_slope_angle(big, 1.0, 0.0)
        assert mz > 0.0 and mx == 1.0 and mz == pytest.approx(1.0 / big, rel=1e-15)


def test_stretched_slope_is_a_drop_in_for_the_kernel_disk_sampler():
    # The GGX disk sampler (ggx.sample_disk, which the
    # kernel inlines through the registry) calls stretched_slope(r/sqrt(s), a, b, alpha_x,
    # alpha_y); for ordinary roughness it is bitwise the same map, beyond it it stays finite.
    rng = np.random.default_rng(3)
    kind = distributions.kind_of("ggx")
    for alpha in ((0.6, 0.6), (0.05, 0.9), (2.0, 0.01), (1e-4, 10.0)):
        params = _params("ggx", *alpha)
        for a, b in rng.uniform(-0.7, 0.7, (500, 2)):
            s = a * a + b * b
            r_over_sqrt_s = math.sqrt(1.0 - s) / s
            want = stretched_slope(r_over_sqrt_s, a, b, *alpha)
            if alpha[0] == alpha[1]:  # the isotropic branch skips the stretch: the same map to rounding
                assert ggx.sample_disk(a, b, s, params) == pytest.approx(want, rel=1e-14, abs=1e-15)
            else:
                assert want == ggx.sample_disk(a, b, s, params)
            assert ggx.sample_disk(a, b, s, params) == distributions.sample_disk(kind, a, b, s, params)


@pytest.mark.parametrize("alpha", [1e-170, 1e200])
def test_walk_with_extreme_roughness_has_no_degenerate_path(alpha):
    cfg = validate({"material": {"distribution": "beckmann", "alpha": alpha, "facet": "mirror"},
                    "incidence": {"theta_i_deg": [30.0], "paths": 4096}, "simulation": {"sensor_resolution": 5}})
    assert simulate(cfg)["degenerate"][0] == 0


# ----------------------------------------------------------------------------- Fresnel


def test_fresnel_and_diffuse_terms_continuous_through_eta_one():
    deltas = sorted([10.0**-k for k in range(1, 17)] + [2.0**-52, 0.0], reverse=True)
    for c in (1e-3, 0.1, 0.5, 1.0):
        f = [fr.fresnel_dielectric(c, 1.0 + d) for d in deltas]
        assert all(np.isfinite(f)) and all(np.diff(f) <= 0.0) and f[-1] == 0.0  # decreasing to 0
    r = [fr.r_e(1.0 + d) for d in deltas]
    ri = [fr.r_i(1.0 + d) for d in deltas]
    assert all(np.diff(r) <= 0.0) and all(np.diff(ri) <= 0.0) and r[-1] == 0.0 and ri[-1] == 0.0
    for d, value in zip(deltas, r):
        assert 0.0 <= value <= 0.34 * ((1.0 + d) - 1.0)  # r_e ~ (eta - 1)/3: no 0 x inf near eta = 1


def _fresnel_decimal(c, eta):
    """W eq. 22 in 800-digit decimal arithmetic (enough for T = 1 - F down to 1e-700)."""
    with decimal.localcontext() as ctx:
        ctx.prec = 800
        c, eta = decimal.Decimal(c), decimal.Decimal(eta)
        g = (eta * eta - 1 + c * c).sqrt()
        r_s = (g - c) / (g + c)
        r_p = (eta * eta * c - g) / (eta * eta * c + g)
        f = (r_s * r_s + r_p * r_p) / 2
        return float(f), float(1 - f)


def test_fresnel_accurate_up_to_the_largest_float():
    # F is not monotone: it dips to ~1/2 at the pseudo-Brewster cosine ~1/eta
    for eta in (1e30, 1e49, 1e50, 1e51, 1e77, 1e100, 1e154, 1e200, 1e300, 1.7e308):
        for c in (5e-324, 1e-300, 0.5 / eta, 1.0 / eta, 2.0 / eta, 1e-20, 1e-3, 0.5, 1.0):
            f_ref, t_ref = _fresnel_decimal(c, eta)
            assert fr.fresnel_dielectric(c, eta) == pytest.approx(f_ref, rel=1e-14, abs=1e-300)
            assert fr.fresnel_transmittance(c, eta) == pytest.approx(t_ref, rel=1e-13, abs=1e-300)
        assert math.isfinite(fr.r_e(eta)) and fr.emergence_probability(1.0, eta) == 1.0
        assert 0.0 <= fr.emergence_probability(0.5, eta) <= 1.0
        # 1 - r_i = (1 - r_e)/eta^2 ~ 16/(3 eta^3): it underflows (to 0, not NaN) from eta ~ 1e108
        assert fr.one_minus_r_i(eta) == pytest.approx(16.0 / (3.0 * eta) / eta / eta, rel=1e-12, abs=1e-320)


@pytest.mark.parametrize("switch", [fr._FRESNEL_SCALED_MIN_ETA, fr._RE_ASYMPTOTIC_MIN_ETA])
def test_no_jump_at_the_large_eta_branch_switches(switch):
    below, above = switch, np.nextafter(switch, np.inf)
    for c in (1e-60, 1e-40, 1e-20, 0.3, 1.0):
        for func in (fr.fresnel_dielectric, fr.fresnel_transmittance):
            assert func(c, above) == pytest.approx(func(c, below), rel=1e-14, abs=1e-300)
    assert fr.one_minus_r_i(above) == pytest.approx(fr.one_minus_r_i(below), rel=1e-14)


# ----------------------------------------------------------------------------- geometry


def _exact_next_surface(surface, x, dx, dz, tan_m):
    """Exact (rational) nearest boundary ahead: (surface, x, gap to the runner-up)."""
    x, dx, dz, t = (Fraction(v) for v in (x, dx, dz, tan_m))
    z = {OPENING: Fraction(0), LEFT: -t * (1 + x), RIGHT: -t * (1 - x)}[surface]
    candidates = []
    if surface != LEFT and dz + t * dx < 0:  # left line z = -t (1 + x)
        candidates.append(((z + t * (1 + x)) / -(dz + t * dx), LEFT))
    if surface != RIGHT and dz - t * dx < 0:
        candidates.append(((z + t * (1 - x)) / -(dz - t * dx), RIGHT))
    if surface != OPENING and dz > 0:
        candidates.append((-z / dz, OPENING))
    if not candidates:
        return NO_HIT, x, None
    candidates.sort()
    s, hit = candidates[0]
    gap = candidates[1][0] - s if len(candidates) > 1 else None
    return hit, x + s * dx, (gap / s if gap is not None and s > 0 else None)


@pytest.mark.parametrize("tan_m", [1e-8, 1e-4, 0.3, 1.0, 1e4, 1e8])
@pytest.mark.parametrize("theta_deg", [89.0, 89.99, 89.99999999999999])
def test_grazing_walk_geometry_matches_exact_arithmetic(tan_m, theta_deg):
    rng = np.random.default_rng(int(tan_m * 1e8) % 1000 + int(theta_deg))
    iz = math.cos(math.radians(theta_deg))
    for _ in range(40):
        phi = rng.uniform(0.0, 2.0 * math.pi)
        dx, dz = -math.sin(math.radians(theta_deg)) * math.cos(phi), -iz
        surface, x = OPENING, rng.uniform(-1.0, 1.0)
        cos_t = 1.0 / math.sqrt(1.0 + tan_m * tan_m)
        sin_t = tan_m * cos_t
        for _ in range(60):  # a mirror walk, reflected exactly as the kernel does
            hit, new_x = next_surface(surface, x, dx, dz, tan_m)
            want, want_x, gap = _exact_next_surface(surface, x, dx, dz, tan_m)
            if gap is None or gap > 1e-9:  # not a near-tie between two boundaries
                assert hit == want
            assert hit != NO_HIT
            lo, hi = {OPENING: (-1.0, 1.0), LEFT: (-1.0, 0.0), RIGHT: (0.0, 1.0)}[hit]
            assert lo <= new_x <= hi  # stays on the boundary of the groove
            if hit == want:
                assert abs(new_x - float(want_x)) <= 1e-9 * max(1.0, abs(float(want_x)))
            if hit == OPENING:
                break
            nx = sin_t if hit == LEFT else -sin_t
            cos_in = -(dz + tan_m * dx) * cos_t if hit == LEFT else -(dz - tan_m * dx) * cos_t
            assert cos_in > 0.0
            dx, dz = dx + 2.0 * cos_in * nx, dz + 2.0 * cos_in * cos_t
            surface, x = hit, new_x


# ----------------------------------------------------------------------------- binning


@pytest.mark.parametrize("resolution", [1, 2, 57, 58])
def test_pole_and_signed_zeros_bin_to_one_cell(resolution):
    half = resolution // 2  # floor((0 + 1)/2 N)
    pole = half * resolution + half
    for x, y in ((0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0)):
        assert direction_to_cell(x, y, 1.0, resolution) == pole
    # a hair off the pole in any direction lands in one of the cells touching it
    for phi in np.linspace(0.0, 2.0 * math.pi, 17):
        cell = direction_to_cell(1e-300 * math.cos(phi), 1e-300 * math.sin(phi), 1.0, resolution)
        assert abs(cell // resolution - half) <= 1 and abs(cell % resolution - half) <= 1


def test_horizon_and_slightly_non_unit_directions_bin_deterministically():
    for phi in np.linspace(0.0, 2.0 * math.pi, 33):
        d = np.array([math.cos(phi), math.sin(phi), 0.0])
        cells = {direction_to_cell(*(d * scale), 57) for scale in (1.0, 1.0 - 1e-15, 1.0 + 1e-15)}
        assert len(cells) == 1 and 0 <= cells.pop() < 57 * 57


# ----------------------------------------------------------------------------- float64


def _types_of(pyfunc, *args):
    copy = numba.njit(pyfunc)  # fresh, uncached copy: its typing is inspectable
    copy(*args)
    return {str(t) for cres in copy.overloads.values() for t in cres.fndesc.typemap.values()}


def _assert_float64_only(types):
    assert not [t for t in types if "float32" in t or "float16" in t or "complex64" in t]
    assert any("float64" in t for t in types)


def test_walk_is_float64_throughout():
    cfg = validate({"material": {"distribution": "gaussian", "sigma": 0.3, "kd": 0.5, "eta": 1.5},
                    "incidence": {"theta_i_deg": [60.0], "paths": 10}})
    sim = Simulation(cfg, threads=1)
    kernel, recorded = sim.walk.kernel, {}

    def record(call):
        recorded["call"] = call
        return kernel(call)

    sim.walk.kernel = record
    sim.compile()  # records the exact call the simulator makes
    call = recorded["call"]
    # the jitted walk of slot 0 with the rows the kernel hands it (vcavity.kernels.loop.SlotKernel)
    slot_rows = kernel.slot_rows(kernel.outputs(1, call.max_order, call.resolution), 0)
    _assert_float64_only(_types_of(kernel.walk.py_func, 0, *loop.arguments(call), *slot_rows))
    _assert_float64_only(_types_of(fr.fresnel_dielectric.py_func, 0.3, 1.5))
    _assert_float64_only(_types_of(direction_to_cell.py_func, 0.1, 0.2, 0.97, 57))
    exits = np.full(4, 0.5)
    _assert_float64_only(_types_of(bin_block.py_func, exits, exits, exits, 4, 57, np.empty(4, np.int64)))
    _assert_float64_only(_types_of(beckmann.sample.py_func, 0.3, 0.7, _params("beckmann", 0.1, 0.5)))
