"""``vcavity sweep`` budget flags (--paths, --seed, --estimator, --target-error, --max-paths):
they mean what they mean for ``vcavity run`` (a point of an overridden sweep has the counts of
the same sweep file edited to those values), the file records them, ``--resume`` with other
ones is refused in one line (exit 2, file untouched), and a bad value names the flag.

Cheap: 2 points x 1 direction x 8 000 paths on 9 x 9 cells of the beckmann +
interfaced_lambertian kernel the suite already compiles. Counts compared bit for bit.
"""

import hashlib
import json

import h5py
import numpy as np
import pytest

from vcavity.cli import main

BASE = ('[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 0.9\neta = 1.5\n'
        "[incidence]\ntheta_i_deg = [30]\npaths = {paths}\n[simulation]\nseed = {seed}\nsensor_resolution = 9\n"
        "{simulation}[sweep]\nalpha = [0.3, 0.6]\n")


def _spec(folder, name, paths=50_000, seed=17, simulation=""):
    path = folder / name
    path.write_text(BASE.format(paths=paths, seed=seed, simulation=simulation))
    return path


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def overridden(tmp_path_factory):
    """The same sweep twice: its file's paths and seed overridden by flags, and edited in."""
    folder = tmp_path_factory.mktemp("overrides")
    spec = _spec(folder, "big.toml")
    out = folder / "flags.h5"
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--paths", "8000", "--seed", "3"]) == 0
    edited = folder / "edited.h5"
    assert main(["sweep", str(_spec(folder, "edited.toml", paths=8000, seed=3)), "-o", str(edited), "-q"]) == 0
    return folder, spec, out, edited


def test_flags_mean_what_the_edited_sweep_file_means(overridden):
    _, _, out, edited = overridden
    with h5py.File(out, "r") as a, h5py.File(edited, "r") as b:
        assert a["paths"][()].tolist() == [[8000], [8000]]
        for name in ("counts", "seed", "albedo"):
            np.testing.assert_array_equal(a[name][()], b[name][()], err_msg=name)
        assert a.attrs["spec_digest"] == b.attrs["spec_digest"]  # the same configs at every point


def test_the_file_records_the_overrides(overridden):
    _, _, out, edited = overridden
    with h5py.File(out, "r") as a, h5py.File(edited, "r") as b:
        assert json.loads(a.attrs["overrides"]) == {"incidence.paths": 8000, "simulation.seed": 3}
        assert json.loads(b.attrs["overrides"]) == {}
        base = json.loads(a.attrs["spec"])["base"]
        assert base["incidence"]["paths"] == 8000 and base["simulation"]["seed"] == 3


def test_resume_with_other_overrides_is_refused_in_one_line(overridden, capsys):
    folder, spec, out, _ = overridden
    before = _sha(out)
    for flags, given in ((["--paths", "9000", "--seed", "3"], "incidence.paths = 9000, simulation.seed = 3"),
                         (["--seed", "3"], "simulation.seed = 3"), ([], "none")):
        capsys.readouterr()
        assert main(["sweep", str(spec), "-o", str(out), "-q", "--resume", *flags]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("vcavity: error: --resume: --output = "), err
        assert "was swept with the overrides incidence.paths = 8000, simulation.seed = 3, this command " \
               f"gives {given};" in err, err
        assert _sha(out) == before
    capsys.readouterr()  # the same flags: nothing left to run, the points are kept
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--resume", "--seed", "3", "--paths", "8000"]) == 0
    assert "2 point(s) x 1 direction(s), 2 done" in capsys.readouterr().err


def test_target_error_and_max_paths_override_as_in_run(tmp_path):
    """--target-error 0.5 stops at the first check (64 blocks of 4096 paths), below the cap
    --max-paths 10^6; the file records both and the stop rule's outcome."""
    out = tmp_path / "target.h5"
    spec = _spec(tmp_path, "target.toml", paths=1000)
    assert main(["sweep", str(spec), "-o", str(out), "-q", "--target-error", "0.5", "--max-paths", "1e6"]) == 0
    with h5py.File(out, "r") as h5:
        assert h5["paths"][()].tolist() == [[64 * 4096], [64 * 4096]]
        assert h5["target_reached"][()].tolist() == [[1], [1]]
        assert h5.attrs["target_error"] == 0.5
        assert json.loads(h5.attrs["overrides"]) == {"simulation.max_paths": 1_000_000,
                                                     "simulation.target_error": 0.5}


def test_estimator_override_reaches_every_point(tmp_path):
    out = tmp_path / "exact_f1.h5"
    assert main(["sweep", str(_spec(tmp_path, "e.toml", paths=4096)), "-o", str(out), "-q",
                 "--estimator", "exact-f1"]) == 0
    with h5py.File(out, "r") as h5:
        assert h5.attrs["estimator"] == "exact-f1"


BAD = [
    (["--paths", "0"], "--paths = '0': must be an integer >= 1"),
    (["--seed", "-1"], "--seed = '-1': must be an integer >= 0"),
    (["--estimator", "fast"], "--estimator: invalid choice: 'fast'"),
    (["--target-error", "2"], "--target-error = '2': expected a number in (0, 1)"),
    (["--max-paths", "5000"], "--max-paths = 5000: applies only with simulation.target_error"),
    (["--estimator", "exact"], "--estimator = 'exact': is for specular facets only"),
]


def _status(argv):
    """main's exit status; argparse refuses a flag's syntax by SystemExit."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.mark.parametrize("flags, message", BAD, ids=[" ".join(b[0]) for b in BAD])
def test_a_bad_override_names_the_flag_and_writes_nothing(tmp_path, capsys, flags, message):
    out = tmp_path / "bad.h5"
    assert _status(["sweep", str(_spec(tmp_path, "s.toml")), "-o", str(out), "-q", *flags]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == [tmp_path / "s.toml"]
