"""Every specialisation of the walk against the general kernel (vcavity/kernels/trace.py).

The specialisations are not separately compiled variants (``trace.variants()`` lists
those): f1 only (``max_bounces = 1``), ``first_binned_order = 2`` and the isotropic
branch of the stretched-slope samplers. Where the random streams line up the check is
bitwise: a mirror facet draws no random number, so an f1-only run consumes exactly the
streams of a full run; ``first_binned_order`` only skips binning. Otherwise (the IL facet
draws per bounce, so later paths of a block see other numbers) the two runs are compared
by a two-sample chi-square (homogeneity) over the f1 cells plus the "not f1" category,
rejecting at p < 1e-3: false-positive rate 1e-3 over the choice of the fixed keys.

Cost: only the kernel variants the default suite already compiles (Beckmann with mirror
facets and with the fig. 7(b) IL facet), ~2e6 paths in all.
"""

import math

import numpy as np
import pytest
from scipy import stats

from vcavity.facet import registry as facets
from vcavity.kernels import trace, walks
from vcavity.microfacet import registry as distributions
from vcavity.microfacet import beckmann, ggx, student_t
from vcavity.rng import BLOCK_SIZE

THETA = math.radians(60.0)
INCIDENT = np.array([math.sin(THETA) * math.cos(0.4), math.sin(THETA) * math.sin(0.4), math.cos(THETA)])
RESOLUTION = 9
COLUMN = {name: k for k, name in enumerate(trace.STATS)}


def _run(facet, values, key, n_paths, max_bounces, max_order, first_binned_order=1):
    dist_kind, params = distributions.params_from("beckmann", {"alpha_x": 0.6, "alpha_y": 0.6})
    facet_kind, variant, data = facets.prepare(facet, values)
    walk = walks.get("v-cavity", dist_kind, facet_kind, variant)
    counts, stat = walk.kernel(walks.WalkCall(
        incident=INCIDENT, direction_key=np.uint64(key), first_block=0, n_blocks=-(-n_paths // BLOCK_SIZE),
        n_paths=n_paths, params=params, facet_data=data, max_bounces=max_bounces, max_order=max_order,
        resolution=RESOLUTION, n_slots=2, first_binned_order=first_binned_order))
    return counts.sum(axis=0), stat  # stat per slot: the columns of trace.STATS


def test_variants_follow_the_registries():
    listed = trace.variants()
    n_facet_variants = sum(len(module.VARIANTS) for module in facets.MODULES)
    assert len(listed) == len(set(listed)) == len(distributions.NAMES) * n_facet_variants
    for dist, facet, variant in listed:
        assert variant in facets.get(facet).VARIANTS and dist in distributions.NAMES
    assert ("beckmann", "interfaced_lambertian", "interfaced lambertian") in listed


def test_f1_only_mirror_run_is_bitwise_the_f1_of_the_full_run():
    n = 3 * BLOCK_SIZE + 123
    full, full_stat = _run("mirror", {}, 11, n, 10_000, 3)
    only, only_stat = _run("mirror", {}, 11, n, 1, 1)
    np.testing.assert_array_equal(only[1], full[1])
    assert only[0].sum() == 0  # nothing beyond order 1 is ever binned
    assert only_stat[:, COLUMN["max_bounces"]].max() == 1 < full_stat[:, COLUMN["max_bounces"]].max()
    # a path that meets a second wall stops there, counted as truncated
    assert only_stat[:, COLUMN["truncated"]].sum() == n - full[1].sum() - only_stat[:, COLUMN["degenerate"]].sum()


def test_f1_only_il_run_agrees_with_the_full_run():
    n = 1_000_000
    il = {"kd": 0.9, "eta": 1.5}
    full, _ = _run("interfaced_lambertian", il, 21, n, 10_000, 3)
    only, only_stat = _run("interfaced_lambertian", il, 22, n, 1, 1)
    assert only_stat[:, COLUMN["max_bounces"]].max() == 1
    table = np.array([only[1], full[1]])
    keep = table.sum(axis=0) >= 20
    rows = np.column_stack([table[:, keep], table[:, ~keep].sum(axis=1), n - table.sum(axis=1)])
    rows = rows[:, rows.sum(axis=0) > 0]
    assert stats.chi2_contingency(rows).pvalue > 1e-3


def test_first_binned_order_two_only_skips_binning_the_first_order():
    il = {"kd": 0.9, "eta": 1.5}
    n = 2 * BLOCK_SIZE + 77
    binned, stat1 = _run("interfaced_lambertian", il, 31, n, 10_000, 3, first_binned_order=1)
    skipped, stat2 = _run("interfaced_lambertian", il, 31, n, 10_000, 3, first_binned_order=2)
    assert skipped[1].sum() == 0
    np.testing.assert_array_equal(skipped[[0, 2, 3]], binned[[0, 2, 3]])
    assert stat2[:, COLUMN["unbinned"]].sum() == binned[1].sum() > 0
    assert stat1[:, COLUMN["unbinned"]].sum() == 0
    np.testing.assert_array_equal(np.delete(stat1, COLUMN["unbinned"], axis=1),
                                  np.delete(stat2, COLUMN["unbinned"], axis=1))


@pytest.mark.parametrize("module, extra", [(beckmann, ()), (ggx, ()), (student_t, (1.7,))])
@pytest.mark.parametrize("alpha", [1e-3, 0.6, 3.0, 1e6])
def test_isotropic_branch_of_sample_disk_matches_the_stretched_slope(module, extra, alpha):
    """alpha_x == alpha_y takes the stretch-free branch; one ulp apart takes the general one."""
    name = module.NAME
    keys = distributions.value_keys(name)
    iso = dict(zip(keys, (alpha, alpha) + extra))
    near = dict(zip(keys, (alpha, np.nextafter(alpha, np.inf)) + extra))
    _, p_iso = distributions.params_from(name, iso)
    _, p_near = distributions.params_from(name, near)
    rng = np.random.default_rng(5)
    checked = 0
    for a, b in rng.uniform(-1.0, 1.0, (3000, 2)):
        s = a * a + b * b
        if not 0.0 < s < 1.0:
            continue
        t1, c1, s1 = module.sample_disk(a, b, s, p_iso)
        t2, c2, s2 = module.sample_disk(a, b, s, p_near)
        assert t1 == pytest.approx(t2, rel=1e-13)
        assert abs(c1 - c2) < 1e-14 and abs(s1 - s2) < 1e-14
        checked += 1
    assert checked > 2000
