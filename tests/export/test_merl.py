"""``vcavity export --format merl``: the file, read back by an independent reader
(tests/reference/merl_reader.py, written from the format's description), against the
table API it was evaluated with.

Tables are synthetic (tests/export/synthetic_table.py: a closed-form BRDF at the cell
centres, nothing simulated) except one tiny run of Beckmann + interfaced Lambertian
without f_inf, the kernel variant the rest of the suite compiles. Nothing here is
statistical: every check is exact, rounding-level, or a bound stated where it is used.
"""

import hashlib

import numpy as np
import pytest

from tests.export.synthetic_table import ANISOTROPIC, synthetic
from tests.reference import merl_reader as ref
from vcavity.cli import main
from vcavity.export import ExportRequest, export

SEED = 20240611


@pytest.fixture(scope="module")
def lobe(tmp_path_factory):
    """Isotropic, mirror-symmetric, not reciprocal; every row at phi_i = 0; orders 0, 1."""
    folder = tmp_path_factory.mktemp("merl")
    table = synthetic(folder / "lobe.h5")
    out = folder / "lobe.binary"
    export(table, "merl", ExportRequest(), out)
    dims, raw = ref.read(out)
    return table, out, dims, raw


def symmetric_eval(table, wi, wo, order=0):
    """The reciprocal part of table.eval: what one MERL bin holds for a pair and its swap."""
    return 0.5 * (table.eval(wi, wo, order=order) + table.eval(wo, wi, order=order))


def centre_directions(i, j, k, phi_h=0.0):
    return ref.directions(ref.bin_centre_angles(i, j, k)[0], phi_h, *ref.bin_centre_angles(i, j, k)[1:])


def random_bins(rng, n):
    return rng.integers(0, 90, n), rng.integers(0, 90, n), rng.integers(0, 180, n)


# ---------------------------------------------------------------------- layout
def test_header_and_size(lobe):
    _, out, dims, _ = lobe
    data = out.read_bytes()
    assert dims == (90, 90, 180)
    assert data[:12] == (90).to_bytes(4, "little") * 2 + (180).to_bytes(4, "little")
    assert len(data) == 12 + 3 * 8 * 90 * 90 * 180 == ref.FILE_BYTES


def test_bin_centres_round_trip_to_table_eval(lobe):
    """A random sample of bins, whose directions the reader computes from the bin centres:
    valid ones hold (f(wi, wo) + f(wo, wi))/2 of table.eval to rounding, the others -1."""
    table, _, _, raw = lobe
    rng = np.random.default_rng(SEED)
    i, j, k = random_bins(rng, 20_000)
    wi, wo = centre_directions(i, j, k)
    up = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
    assert 0.3 < up.mean() < 0.95  # both kinds are sampled
    values = ref.scaled(raw[:, i, j, k])
    expected = symmetric_eval(table, wi[up], wo[up])
    for channel in range(3):
        np.testing.assert_allclose(values[channel, up], expected, rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(raw[:, i[~up], j[~up], k[~up]], -1.0)


def test_invalid_bins_are_exactly_those_below_the_horizon(lobe):
    """Over the whole file: a bin is negative iff its centre has wi or wo below the horizon;
    every other bin is a positive BRDF value (the synthetic f is > 0 everywhere)."""
    _, _, _, raw = lobe
    j, k = np.meshgrid(np.arange(90), np.arange(180), indexing="ij")
    for i in range(90):
        wi, wo = centre_directions(np.full(j.shape, i), j, k)
        below = (wi[..., 2] <= 0.0) | (wo[..., 2] <= 0.0)
        np.testing.assert_array_equal(raw[0, i] < 0.0, below, err_msg=f"theta_h bin {i}")
        assert np.all(raw[:, i][:, ~below] > 0.0)


def test_channels_are_grey_through_the_scales(lobe):
    """Stored f / scale: red / green = 1.15 and red / blue = 1.66, the ratios of the scales."""
    _, _, _, raw = lobe
    valid = raw[0] > 0.0
    np.testing.assert_allclose(raw[0][valid] / raw[1][valid], 1.15, rtol=1e-14)
    np.testing.assert_allclose(raw[0][valid] / raw[2][valid], 1.66, rtol=1e-14)
    values = ref.scaled(raw)
    np.testing.assert_allclose(values[1][valid], values[0][valid], rtol=1e-14)
    np.testing.assert_allclose(values[2][valid], values[0][valid], rtol=1e-14)


def test_order_is_the_requested_one(lobe, tmp_path):
    """Order 1 of the synthetic table is half of order 0: counts // 2, exact to one count in
    the smallest cell count (~5e9 at 1e15 paths), hence rtol 1e-9."""
    table, _, _, raw = lobe
    out = tmp_path / "f1.binary"
    export(table, "merl", ExportRequest(order=1, order_text="1"), out)
    _, raw_1 = ref.read(out)
    valid = raw[0] > 0.0
    np.testing.assert_allclose(raw_1[:, valid], 0.5 * raw[:, valid], rtol=1e-9)
    np.testing.assert_array_equal(raw_1[:, ~valid], -1.0)


# ---------------------------------------------------------------------- lookups
def _tangents(w):
    """Two unit tangents of the sphere at each unit vector ``w`` (n, 3)."""
    helper = np.where(np.abs(w[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    a = np.cross(w, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(w, a)


def _angle(a, b):
    return np.arccos(np.clip(np.sum(a * b, -1), -1.0, 1.0))


def _random_pairs(rng, n, lo_deg=3.0, hi_deg=87.0):
    """Pairs with theta_i, theta_o in [lo, hi] deg, uniform in cos theta and phi. The pole
    is left out: an isotropic table rotates its rows by phi(wi), so eval varies quickly
    (by the grid's small anisotropy) as wi crosses the pole."""
    cos = rng.uniform(np.cos(np.radians(hi_deg)), np.cos(np.radians(lo_deg)), (2, n))
    phi = rng.uniform(-np.pi, np.pi, (2, n))
    theta = np.arccos(cos)
    return (np.stack([np.sin(theta[0]) * np.cos(phi[0]), np.sin(theta[0]) * np.sin(phi[0]), cos[0]], -1),
            np.stack([np.sin(theta[1]) * np.cos(phi[1]), np.sin(theta[1]) * np.sin(phi[1]), cos[1]], -1))


def _slope(table, wi, wo, step=1e-4):
    """Largest gradient norm of symmetric_eval over wi and over wo (central differences)."""
    norms = []
    for which in (0, 1):
        pair, grad = [wi, wo], 0.0
        for tangent in _tangents(pair[which]):
            plus, minus = list(pair), list(pair)
            plus[which] = pair[which] + step * tangent
            minus[which] = pair[which] - step * tangent
            plus[which] /= np.linalg.norm(plus[which], axis=1, keepdims=True)
            minus[which] /= np.linalg.norm(minus[which], axis=1, keepdims=True)
            grad = grad + ((symmetric_eval(table, *plus) - symmetric_eval(table, *minus)) / (2 * step)) ** 2
        norms.append(np.sqrt(grad))
    return np.maximum(*norms)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_lookup_at_random_pairs_is_within_the_bin_quantisation(lobe):
    """The reader's nearest-bin value at random (wi, wo) against the table at (wi, wo).

    The file is reciprocal and the table is not, so the comparison is with the table's
    reciprocal part, symmetric_eval. The bin centre (wi_c, wo_c) is taken at the query's
    phi_h and matched to (wi, wo) or to the swapped pair (the phi_d fold), whichever is
    nearer. Bound (first order): |Δf| <= L (∠(wi, wi_c) + ∠(wo, wo_c)), L the largest
    gradient norm of symmetric_eval over wi or wo (central differences) at the query, the
    middle of the segment and the centre, times 1.5 for slope changes between them. The
    measured worst error is 0.998 of L d (before the 1.5); the bound is ~1 % of f at the
    median (bins are 0.5-2 degrees from the queries) and the error ~0.4 %.
    """
    table, _, _, raw = lobe
    rng = np.random.default_rng(SEED + 1)
    wi, wo = _random_pairs(rng, 20_000)
    got = ref.lookup(raw, wi, wo)
    theta_h, phi_h, theta_d, phi_d = ref.half_diff(wi, wo)
    wi_c, wo_c = centre_directions(*ref.bin_indices(theta_h, theta_d, phi_d), phi_h=phi_h)
    inside = (wi_c[:, 2] > 0.0) & (wo_c[:, 2] > 0.0)  # else the bin is marked invalid
    assert inside.mean() > 0.97
    assert np.all(got[:, ~inside] < 0.0)
    direct, swapped = (_angle(wi, wi_c) + _angle(wo, wo_c), _angle(wi, wo_c) + _angle(wo, wi_c))
    swap = (swapped < direct)[:, None]
    near_i, near_o = np.where(swap, wo_c, wi_c), np.where(swap, wi_c, wo_c)
    distance = np.minimum(direct, swapped)
    slope = np.max([_slope(table, a, b) for a, b in
                    ((wi, wo), (_unit(wi + near_i), _unit(wo + near_o)), (near_i, near_o))], axis=0)
    error = np.abs(got[0] - symmetric_eval(table, wi, wo))[inside]
    bound = 1.5 * slope[inside] * distance[inside] + 1e-12
    assert np.all(error <= bound), f"worst error / bound {np.max(error / bound):.3g}"
    assert np.max(error / bound) > 0.5  # the bound is tight: a wrong bin would exceed it
    assert np.median(bound / got[0][inside]) < 0.03  # and small


def test_written_values_are_reciprocal_and_mirror_symmetric(lobe):
    """One bin serves (wi, wo) and (wo, wi) (the reader folds phi_d + pi onto phi_d), and
    the export stores the mean of both. For a table mirror-symmetric about its plane of
    incidence (rows at phi_i = 0), bin (i, j, 179 - k) is the mirrored swapped pair of bin
    (i, j, k), so they hold the same value, although the table itself is not reciprocal."""
    table, _, _, raw = lobe
    rng = np.random.default_rng(SEED + 2)
    wi, wo = _random_pairs(rng, 5_000)
    assert np.max(np.abs(table.eval(wi, wo) - table.eval(wo, wi))) > 0.01  # not reciprocal
    np.testing.assert_array_equal(ref.lookup(raw, wi, wo), ref.lookup(raw, wo, wi))
    valid = raw[0] > 0.0
    np.testing.assert_array_equal(valid, valid[:, :, ::-1])
    np.testing.assert_allclose(raw[:, valid], raw[:, :, :, ::-1][:, valid], rtol=1e-12)


# ---------------------------------------------------------------------- CLI
def _config(folder):
    path = folder / "no_f_inf.toml"
    path.write_text('[material]\ndistribution = "beckmann"\nalpha = 0.6\nkd = 0.9\neta = 1.5\n'
                    "[incidence]\ntheta_i_deg = [0, 40]\nphi_i_deg = 0\npaths = 20000\n"
                    "[simulation]\nseed = 3\nmax_order = 2\ntrack_all_orders = false\n"
                    "sensor_resolution = 9\n")
    return path


@pytest.fixture(scope="module")
def cli_tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("merl_cli")
    run = folder / "no_f_inf.h5"
    assert main(["run", str(_config(folder)), "-o", str(run), "-q"]) == 0
    tables = {"run": run}
    for name, options in {"lobe": {}, "aniso": {"material": ANISOTROPIC},
                          "one_theta": {"theta_deg": (30,)},
                          "two_azimuths": {"theta_deg": (30, 30), "phi_deg": (0, 90)}}.items():
        tables[name] = folder / f"{name}.h5"
        synthetic(tables[name], **options)
    return tables


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_run_without_f_inf_has_orders_1_and_2_only(cli_tables):
    from vcavity import open_table

    np.testing.assert_array_equal(open_table(cli_tables["run"]).order, [1, 2])


@pytest.mark.parametrize("name, order", [("lobe", "0"), ("run", "1"), ("run", "f2")])
def test_cli_writes_the_file(cli_tables, tmp_path, capsys, name, order):
    out = tmp_path / "out.binary"
    assert main(["export", str(cli_tables[name]), str(out), "--format", "merl", "--order", order]) == 0
    assert "wrote" in capsys.readouterr().out
    assert out.stat().st_size == ref.FILE_BYTES
    dims, raw = ref.read(out)
    assert dims == (90, 90, 180) and np.any(raw > 0.0)
    assert list(tmp_path.glob(".out.binary.*.tmp")) == []


@pytest.mark.parametrize("name, order, message", [
    ("aniso", "0", "MERL files are isotropic"),
    ("lobe", "3", "has orders 0 (f_inf), 1"),
    ("run", "0", "has orders 1, 2"),
    ("run", "inf", "has orders 1, 2"),
    ("one_theta", "0", "one incident polar angle (theta_i_deg = 30)"),
    ("two_azimuths", "0", "one incident polar angle (theta_i_deg = 30)"),
])
def test_cli_refusals_are_one_line_and_touch_nothing(cli_tables, tmp_path, capsys, name, order, message):
    out = tmp_path / "out.binary"
    arguments = ["export", str(cli_tables[name]), str(out), "--format", "merl", "--order", order]
    assert main(arguments) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert not out.exists()
    out.write_bytes(b"an older file")
    before = _sha256(out)
    assert main(arguments + ["--overwrite"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert _sha256(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.binary"]
