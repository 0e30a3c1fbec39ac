"""Tables and sweep files are checked when read: an edited copy of a valid file holding a
value no run writes (NaN or negated brdf, albedo x10, zeroed solid angles, repeated
orders, inconsistent angles, fractional counts, a deterministic table with paths, flags out of range)
is refused by ``open_table`` / ``open_sweep`` with a one-line ``TableFormatError`` naming
the dataset, and every command reading it exits 2 with that line; valid tables of every
estimator (built with the estimators' own code, written by write_table) still open.

Nothing here is statistical: the files are fixed, each edit is deterministic.
"""

import shutil

import h5py
import numpy as np
import pytest

from tests.export.synthetic_sweeps import synthetic_sweep
from tests.io.checksum_reference import reseal
from vcavity.cli import main
from vcavity.estimators import registry as estimators
from vcavity.estimators.counts import binomial
from vcavity.estimators.paper import weighted
from vcavity.sensor.mirror import mirror_cells
from vcavity.io.checks import TableFormatError
from vcavity.io.sweep_table import SweepFormatError, open_sweep
from vcavity.io.table import open_table


def _set(name, change):
    """An edit: replace dataset ``name`` by ``change(values)`` (same dtype and place)."""
    def edit(h5):
        h5[name][...] = change(h5[name][()])
    return edit


def _replace(name, change):
    """An edit that may change the dtype: delete dataset ``name``, create it anew."""
    def edit(h5):
        values = change(h5[name][()])
        del h5[name]
        h5[name] = values
    return edit


def _attr(name, value):
    def edit(h5):
        h5.attrs[name] = value
    return edit


def _first(name, value):
    """Set the first element of dataset ``name`` to ``value``."""
    def change(a):
        a = a.copy()
        a.flat[0] = value
        return a
    return _set(name, change)


# (id, edit, dataset or attribute the message must name)
TABLE_DEFECTS = [
    ("brdf-nan", _set("brdf", lambda a: np.full_like(a, np.nan)), "brdf"),
    ("brdf-negated", _set("brdf", lambda a: -a), "brdf"),
    ("brdf-inf", _first("brdf", np.inf), "brdf"),
    ("stderr-nan", _first("brdf_stderr", np.nan), "brdf_stderr"),
    ("albedo-x10", _set("albedo", lambda a: 10 * a), "albedo"),
    ("albedo-one-order", _set("albedo", lambda a: a * np.where(np.arange(a.shape[1]) == 2, 1.001, 1.0)), "albedo"),
    ("proj-solid-angle-0", _set("cell_projected_solid_angle", np.zeros_like), "cell_projected_solid_angle"),
    ("solid-angle-x2", _set("cell_solid_angle", lambda a: 2 * a), "cell_solid_angle"),
    ("theta-o-shifted", _set("theta_o", lambda a: a + 0.01), "theta_o"),
    ("phi-o-nan", _first("phi_o", np.nan), "phi_o"),
    ("order-repeated", _set("order", lambda a: np.array([0, 1, 1, 3])), "order"),
    ("order-unsorted", _set("order", lambda a: np.array([0, 2, 1, 3])), "order"),
    ("theta-i-deg-nan", _first("theta_i_deg", np.nan), "theta_i_deg"),
    ("theta-i-moved", _set("theta_i", lambda a: a * 0.9), "theta_i_deg"),
    ("phi-i-deg-off", _set("phi_i_deg", lambda a: a + 1.0), "phi_i_deg"),
    ("counts-fractional", _replace("counts", lambda a: a + 0.5), "counts"),
    ("paths-fractional", _replace("paths", lambda a: a + 0.5), "paths"),
    ("estimator-not-a-name", _attr("estimator", 5), "estimator"),
    ("deterministic-with-paths", _attr("deterministic", 1), "paths"),
    ("order-source-3", _first("order_source", 3), "order_source"),
    ("folded-2", _first("folded", 2), "folded"),
    ("target-reached-5", _first("target_reached", 5), "target_reached"),
    ("absorbed-above-1", _first("absorbed", 1.5), "absorbed"),
    ("truncated-negative", _first("truncated", -0.1), "truncated"),
    ("relative-error-negative", _first("relative_error", -1.0), "relative_error"),
    ("max-bounces-negative", _first("max_bounces_seen", -1), "max_bounces_seen"),
]


def _edited(source, tmp_path, edit, name="edited.h5", sealed=False):
    """A copy of ``source`` edited by ``edit``; ``sealed``: a sweep whose per-point checksums
    are then recomputed (else the edited points are read as not done, see test_sweep_commit)."""
    target = tmp_path / name
    shutil.copyfile(source, target)
    with h5py.File(target, "a") as h5:
        edit(h5)
    if sealed:
        reseal(target)
    return target


@pytest.mark.parametrize("edit, dataset", [d[1:] for d in TABLE_DEFECTS], ids=[d[0] for d in TABLE_DEFECTS])
def test_open_table_refuses_an_edited_table_naming_the_dataset(written, tmp_path, edit, dataset):
    path, _ = written
    open_table(path)  # the valid original opens
    bad = _edited(path, tmp_path, edit)
    with pytest.raises(TableFormatError) as info:
        open_table(bad)
    message = str(info.value)
    assert "\n" not in message and str(bad) in message
    kind = "attribute" if dataset == "estimator" else "dataset"
    assert f"{kind} '{dataset}'" in message


COMMANDS = {
    "info": lambda t, out: ["info", t],
    "compare": lambda t, out: ["compare", t],
    "plot": lambda t, out: ["plot", t, "-o", out + ".png"],
    "export-csv": lambda t, out: ["export", t, out + ".csv", "--format", "csv", "--theta-i", "30"],
    "export-merl": lambda t, out: ["export", t, out + ".binary", "--format", "merl"],
}


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("defect", ["brdf-nan", "albedo-x10", "counts-fractional"])
def test_every_command_refuses_a_defective_table_in_one_line(written, tmp_path, capsys, command, defect):
    path, _ = written
    _, edit, dataset = next(d for d in TABLE_DEFECTS if d[0] == defect)
    bad = _edited(path, tmp_path, edit)
    before = sorted(p.name for p in tmp_path.iterdir())
    status = main(COMMANDS[command](str(bad), str(tmp_path / "out")))
    captured = capsys.readouterr()
    assert status == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: ") and f"dataset '{dataset}'" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


# --- valid tables of every estimator open: the albedo tolerance is not too tight ---------

def _estimated_table(tmp_path, sensor, write, consistent_run, estimator, fold):
    """A table whose brdf, stderr and albedo come from the estimators' own code (exact-f1
    with random model integrals, paper with random integer weights), as the pipeline
    writes them; ``fold`` folds every direction about phi_i = 0."""
    run = consistent_run(17, sensor)
    run["theta_i"] = np.array([0.1, 0.4, 0.9])
    run["phi_i"] = np.zeros(3)
    rng = np.random.default_rng(5)
    order = run["order"]
    area = sensor.cell_projected_solid_angle
    mirror = mirror_cells(sensor, 0.0) if fold else None
    brdf, stderr, albedo = (np.zeros(run["counts"].shape), np.zeros(run["counts"].shape),
                            np.zeros(run["counts"].shape[:2]))
    for j in range(3):
        if estimator == "paper":
            q = rng.integers(0, 1000, run["counts"].shape[1:])
            e = weighted(q, q * q, int(run["paths"][j]), 997.0, area, mirror)
        else:
            f1 = rng.uniform(0, 1, sensor.n_cells) * area / np.pi if estimator == "exact-f1" else None
            e = binomial(run["counts"][j], int(run["paths"][j]), order, area, mirror,
                         f1, None if f1 is None else 1e-3 * f1)
        brdf[j], stderr[j], albedo[j] = e.brdf, e.brdf_stderr, e.albedo
    tabulated = {"brdf": brdf, "brdf_stderr": stderr, "albedo": albedo, "order_source": estimators.get(estimator).order_source(order),
                 "folded": np.full(3, int(fold), np.int8)}
    path = tmp_path / f"{estimator}-{fold}.h5"
    write(path, run, sensor, tabulated=tabulated, run_attrs={"estimator": estimator})
    return path, albedo


@pytest.mark.parametrize("estimator", ["analog", "exact-f1", "paper"])
@pytest.mark.parametrize("fold", [False, True])
def test_tables_of_every_estimator_open(tmp_path, sensor, write, consistent_run, estimator, fold):
    path, albedo = _estimated_table(tmp_path, sensor, write, consistent_run, estimator, fold)
    table = open_table(path)
    np.testing.assert_array_equal(table.albedo, albedo)
    assert table.estimator == estimator


# --- sweep files --------------------------------------------------------------------------

def _sweep(tmp_path):
    return synthetic_sweep(tmp_path / "sweep.h5", [("alpha", [0.2, 0.5]), ("theta_i_deg", [0.0, 40.0])],
                           lambda coords, k: 0.5 / (k + 1), pending=[{"alpha": 0.5}])


SWEEP_DEFECTS = [
    ("done-2", _first("done", 2), "done"),
    ("done-negative", _first("done", -1), "done"),
    ("brdf-nan", _first("brdf", np.nan), "brdf"),
    ("brdf-negated", _set("brdf", lambda a: -a), "brdf"),
    ("albedo-x10", _set("albedo", lambda a: 10 * a), "albedo"),
    ("proj-solid-angle-0", _set("cell_projected_solid_angle", np.zeros_like), "cell_projected_solid_angle"),
    ("order-repeated", _set("order", lambda a: np.array([0, 1, 1])), "order"),
    ("theta-i-radians-off", _set("theta_i", lambda a: a + 0.1), "theta_i_deg"),
    ("counts-fractional", _replace("counts", lambda a: a + 0.5), "counts"),
    ("paths-0-where-done", _first("paths", 0), "paths"),
    ("absorbed-nan-where-done", _first("absorbed", np.nan), "absorbed"),
    ("estimator-empty", _attr("estimator", ""), "estimator"),
]


@pytest.mark.parametrize("edit, dataset", [d[1:] for d in SWEEP_DEFECTS], ids=[d[0] for d in SWEEP_DEFECTS])
def test_open_sweep_refuses_an_edited_sweep_naming_the_dataset(tmp_path, edit, dataset):
    path = _sweep(tmp_path)
    assert open_sweep(path).n_done() == 1  # the valid original opens; NaN of the pending point is fine
    bad = _edited(path, tmp_path, edit, sealed=True)
    with pytest.raises(SweepFormatError) as info:
        open_sweep(bad)
    message = str(info.value)
    assert "\n" not in message and str(bad) in message
    kind = "attribute" if dataset == "estimator" else "dataset"
    assert f"{kind} '{dataset}'" in message


def test_a_sweep_error_is_the_table_error():
    assert SweepFormatError is TableFormatError and issubclass(TableFormatError, ValueError)


SWEEP_TOML = """\
[material]
distribution = "beckmann"
alpha = 0.3
kd = 0.5
[incidence]
theta_i_deg = [0, 40]
paths = 4096
[simulation]
sensor_resolution = 1
[sweep]
alpha = [0.2, 0.5]
"""

SWEEP_COMMANDS = {
    "info": lambda s, out, toml: ["info", s],
    "plot": lambda s, out, toml: ["plot", s, "-o", out + ".png"],
    "export-lut": lambda s, out, toml: ["export", s, out + ".npz", "--format", "albedo-lut"],
    "sweep-resume": lambda s, out, toml: ["sweep", toml, "-o", s, "--resume", "-q"],
}


@pytest.mark.parametrize("command", SWEEP_COMMANDS)
def test_every_command_refuses_a_sweep_with_done_2_in_one_line(tmp_path, capsys, command):
    bad = _edited(_sweep(tmp_path), tmp_path, _first("done", 2))
    toml = tmp_path / "s.toml"
    toml.write_text(SWEEP_TOML)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    status = main(SWEEP_COMMANDS[command](str(bad), str(tmp_path / "out"), str(toml)))
    captured = capsys.readouterr()
    assert status == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: ") and "dataset 'done'" in lines[0]
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # nothing written or changed


def test_resume_of_a_default_output_names_it_as_the_default(tmp_path, capsys):
    """Without -o the output is the sweep file's name with .h5: a refusal of --resume names
    that default, not an --output that was never given."""
    toml = tmp_path / "s.toml"
    toml.write_text(SWEEP_TOML)
    _edited(_sweep(tmp_path), tmp_path, _first("done", 2), name="s.h5")
    assert main(["sweep", str(toml), "--resume", "-q"]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and "--output" not in lines[0]
    assert lines[0].startswith(f"vcavity: error: --resume: output (default: the config's name with .h5) = "
                               f"{str(tmp_path / 's.h5')!r} cannot be resumed: dataset 'done'")
