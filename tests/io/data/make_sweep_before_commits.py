"""Regenerate sweep_before_commits.h5, the fixture of tests/sweep/test_commit.py's test of a
sweep file written before points were committed in place (gzip-chunked cell datasets, no
``checksum`` dataset). It must be written by vcavity at commit e091c4d (the last commit
that rewrote the whole file after each point), not by the current code:

    git worktree add --detach /tmp/vcavity-e091c4d e091c4d
    cd tests/io/data && NUMBA_CACHE_DIR=/tmp/nc-e091c4d PYTHONPATH=/tmp/vcavity-e091c4d \\
        python make_sweep_before_commits.py

The sweep is tests/sweep/test_commit.py's (BASE + GRID there, copied below), stopped after
its first point as Ctrl-C would: done = [[1, 0], [0, 0]].
"""

import tempfile
from pathlib import Path

import h5py

import vcavity.io.sweep_table as sweep_table
from vcavity.sweep import run as sweep_run
from vcavity.sweep import spec as sweep_mod

assert "checksum" not in sweep_table.VARIABLES, f"not the writer of e091c4d: {sweep_table.__file__}"

TOML = ('[material]\ndistribution = "beckmann"\nfacet = "interfaced_lambertian"\nkd = 0.9\n'
        "[incidence]\npaths = 20_000\n[simulation]\nseed = 17\nsensor_resolution = 9\n"
        "[sweep]\ntheta_i_deg = [0, 60]\nalpha = [0.3, 0.6]\neta = [1.3, 1.5]\n")
OUT = Path(__file__).with_name("sweep_before_commits.h5")


def stop(point, data):
    raise KeyboardInterrupt


with tempfile.TemporaryDirectory() as folder:
    spec = Path(folder) / "grid.toml"
    spec.write_text(TOML)
    sweep = sweep_mod.load(spec)
    OUT.unlink(missing_ok=True)
    _, data, _ = sweep_run.plan_output(sweep, str(OUT), str(spec))
    try:
        sweep_run.run(sweep, OUT, data, on_point=stop, threads=1)
    except KeyboardInterrupt:
        pass
with h5py.File(OUT, "r") as h5:
    assert h5["done"][()].tolist() == [[1, 0], [0, 0]] and h5["brdf"].compression == "gzip"
print(f"wrote {OUT}")
