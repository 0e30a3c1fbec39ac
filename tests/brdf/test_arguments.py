"""The table API refuses bad arguments and normalises any finite direction (vcavity.brdf.arguments).

Out-of-range uniforms and non-finite directions raise a ValueError naming the argument;
denormal or huge non-unit vectors give the value at their direction. On the synthetic
``lobe`` table of tests/brdf/test_table_brdf.py (closed form, no simulation). Deterministic.
"""

import re

import numpy as np
import pytest

from tests.brdf.test_table_brdf import direction, lobe, synthetic


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    return {"lobe": synthetic(tmp_path_factory.mktemp("brdf-arguments") / "lobe.h5", lobe)}


@pytest.mark.parametrize("u1, u2, name, shown", [
    (-0.1, 0.5, "u1", "-0.1"), (1.0, 0.5, "u1", "1.0"), (np.nan, 0.5, "u1", "nan"),
    (0.5, -3.0, "u2", "-3.0"), (0.5, [0.2, np.inf], "u2[1]", "inf"), ([0.3, 0.2, 7.0], 0.5, "u1[2]", "7.0")])
def test_sample_refuses_uniforms_outside_0_1(tables, u1, u2, name, shown):
    """Out-of-range or NaN uniforms have no direction to map to: a ValueError naming the
    argument and value, not NaN directions or a weighted direction drawn from u2 = -3."""
    with pytest.raises(ValueError, match="^" + re.escape(f"{name} = {shown}: must be in [0, 1)") + "$"):
        tables["lobe"].sample(direction(0.4, 0.2), u1, u2)


@pytest.mark.parametrize("bad", [[np.nan, 0.0, 1.0], [0.0, 0.0, np.inf], [0.0, -np.inf, 0.5]])
def test_non_finite_directions_are_refused(tables, bad):
    """A NaN or infinite component is a caller's bug: ValueError naming wi or wo, never a
    silent 0 from eval, pdf, albedo_at or sample."""
    t = tables["lobe"]
    good = direction(0.4, 0.2)
    two = np.stack([good, bad])  # the bad one at index 1
    for call, name in ((lambda: t.eval(two, good), "wi"), (lambda: t.eval(good, two), "wo"),
                       (lambda: t.pdf(good, two), "wo"), (lambda: t.albedo_at(two), "wi"),
                       (lambda: t.sample(two, 0.3, 0.6), "wi")):
        with pytest.raises(ValueError, match=rf"^{name}\[1\] = .*: directions must be finite$"):
            call()


@pytest.mark.parametrize("power", [-1060, -1030, -600, 600, 1000, 1020])
def test_tiny_and_huge_directions_give_the_value_at_their_direction(tables, power):
    """Denormal or huge non-unit vectors are normalised without under- or overflow: the
    value is the one of the same vector at ordinary scale. The vectors have few mantissa
    bits and the scales are powers of two, so the scaled vectors are exact (even denormal
    at 2^-1060) and point exactly where the unscaled ones do."""
    t = tables["lobe"]
    wi, wo = np.array([0.375, -0.5, 1.25]), np.array([-0.75, 0.25, 0.5])
    scale = 2.0 ** power
    assert np.all(wi * scale / scale == wi) and np.all(wo * scale / scale == wo)  # exact
    for w_in, w_out in ((wi * scale, wo), (wi, wo * scale), (wi * scale, wo * scale)):
        assert t.eval(w_in, w_out) == pytest.approx(t.eval(wi, wo), rel=1e-14)
        assert t.pdf(w_in, w_out) == pytest.approx(t.pdf(wi, wo), rel=1e-14)
    assert t.albedo_at(wi * scale) == pytest.approx(t.albedo_at(wi), rel=1e-14)
    assert t.eval(wi, wo) > 0.0 and t.albedo_at(wi) > 0.0
