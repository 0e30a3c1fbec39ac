"""The registry of estimators (vcavity/estimators/registry.py): every module offers the
interface, names the walk it needs and keeps only what that walk gives; and a fifth
estimator is one module plus one registry line, shown with a stand-in estimator planted in
a copy of the package (as tests/test_architecture.py plants imports). Deterministic, except
the stand-in's run, whose table is checked against the analog formula recomputed here
(exact: the same counts, no false positives)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vcavity import config as config_mod
from vcavity.estimators import registry as estimators
from vcavity.kernels import registry as walk_registry

ROOT = Path(__file__).resolve().parents[2]
MATERIALS = {"v-cavity": config_mod.validate({"material": {"alpha": 0.5, "facet": "mirror"}}).material,
             "smith": config_mod.validate({"material": {"alpha": 0.5, "facet": "mirror",
                                                        "microsurface": "smith"}}).material}


def test_names_are_registered_once_with_the_default_first():
    assert estimators.names() == tuple(m.NAME for m in estimators.MODULES)
    assert len(set(estimators.names())) == len(estimators.MODULES) == len(estimators.ESTIMATOR_MODULES)
    assert estimators.default() == "analog" == config_mod.RunConfig.estimator
    with pytest.raises(KeyError, match="unknown estimator 'magic'; registered: analog, exact-f1"):
        estimators.get("magic")
    assert estimators.find("magic") is None


@pytest.mark.parametrize("module", estimators.MODULES, ids=estimators.names())
def test_every_estimator_has_the_interface_and_keeps_only_what_its_walk_gives(module):
    assert all(hasattr(module, name) for name in estimators.INTERFACE)
    assert module.DESCRIPTION and "\n" not in module.DESCRIPTION
    assert module.STDERR_RULE and "\n" not in module.STDERR_RULE
    assert module.FIRST_BINNED_ORDER in (1, 2)
    for surface, material in MATERIALS.items():
        name = module.walk(material)
        if name is None:  # a model's table: nothing traced, nothing kept
            assert module.TALLIES == () and module.STATS == ()
            continue
        walk = walk_registry.get(name)
        assert set(module.TALLIES) <= set(walk.TALLIES) and set(module.STATS) <= set(walk.STATS), surface
        assert module.TALLIES[0] == "counts"  # the table's raw counts come from the first plane
    flags = module.order_source((0, 1, 2))
    assert flags.dtype == np.int8 and flags.shape == (3,) and set(flags.tolist()) <= {0, 1, 2}


STAND_IN = '''"""A stand-in estimator: the analog one without the mirror fold."""

from vcavity.estimators import analog
from vcavity.estimators.counts import binomial, table_counts

NAME = "stand-in"
DESCRIPTION = "the analog estimator without the mirror fold (a test's stand-in)"
FIRST_BINNED_ORDER = analog.FIRST_BINNED_ORDER
TALLIES = analog.TALLIES
STATS = analog.STATS
COUNTS_UNTESTABLE = None
STDERR_RULE = "binomial, as the analog estimator's"
walk, check, models, lost_fractions, landed = analog.walk, analog.check, analog.models, analog.lost_fractions, analog.landed
order_source, albedo_stderr = analog.order_source, analog.albedo_stderr


def estimate(j, tally, paths, config, sensor, models=None):
    return binomial(table_counts(tally[0], config.track_all_orders), paths, config.orders,
                    sensor.cell_projected_solid_angle)
'''

PROBE = '''
import sys
import numpy as np
from vcavity.io.table import open_table
from vcavity.cli import main

status = main(["run", sys.argv[1], "-o", sys.argv[2], "-q", "--threads", "1"])
table = open_table(sys.argv[2])
print(status, table.estimator, table.folded.tolist(), int(table.paths[0]))
np.save(sys.argv[3], np.stack([table.brdf, table.counts.astype(float)]))
'''


def test_a_fifth_estimator_is_one_module_and_one_registry_line(tmp_path):
    """In a copy of the package: ``stand_in.py`` plus its name in ESTIMATOR_MODULES, no
    other edit. The config accepts it, ``--help`` lists it, a run writes its table
    (unfolded where the analog one folds: brdf = counts / (N Ω⊥) of every cell, recomputed
    here) under its name, and an unknown name is still refused."""
    shutil.copytree(ROOT / "vcavity", tmp_path / "vcavity", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "vcavity" / "estimators" / "stand_in.py").write_text(STAND_IN)
    registry = tmp_path / "vcavity" / "estimators" / "registry.py"
    text = registry.read_text()
    line = 'ESTIMATOR_MODULES = ("analog", "exact_f1", "paper", "exact")'
    assert line in text
    registry.write_text(text.replace(line, line[:-1] + ', "stand_in")'))
    config = tmp_path / "run.toml"
    config.write_text('[material]\ndistribution = "ggx"\nalpha = 0.4\nfacet = "mirror"\n'
                      '[incidence]\ntheta_i_deg = [30]\nphi_i_deg = 0\npaths = 20000\n'
                      '[simulation]\nsensor_resolution = 9\nestimator = "stand-in"\n')
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    run = subprocess.run([sys.executable, "-c", PROBE, str(config), str(tmp_path / "t.h5"), str(tmp_path / "v.npy")],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    probe = run.stdout.splitlines()[-1]  # (the run's own report comes first)
    assert probe.split()[:2] == ["0", "stand-in"] and "[0]" in probe  # phi_i = 0 would fold
    brdf, counts = np.load(tmp_path / "v.npy")
    from vcavity.sensor.grid import EqualAreaSensor

    area = EqualAreaSensor(9).cell_projected_solid_angle
    np.testing.assert_allclose(brdf, counts / (20000 * area), rtol=1e-15)
    helps = subprocess.run([sys.executable, "-m", "vcavity", "run", "--help"], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=120)
    assert "stand-in: the analog estimator without the mirror fold" in " ".join(helps.stdout.split())
    (tmp_path / "bad.toml").write_text(config.read_text().replace('"stand-in"', '"stand-out"'))
    bad = subprocess.run([sys.executable, "-m", "vcavity", "run", str(tmp_path / "bad.toml")], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "'analog', 'exact-f1', 'paper', 'exact', 'stand-in'" in bad.stderr
