"""``--dask`` is checked before anything is compiled or traced, in ``run`` and ``sweep``
alike: an address that is none, ``local:0`` and ``local:N`` beyond the cores here are one
line each (the ``--dask = ...`` prefix once), exit status 2, no output; an address where
no scheduler answers is one line too (not a traceback after the connection timeout)."""

import os

import pytest

from vcavity.cli import main

CONFIG = ('[material]\ndistribution = "beckmann"\nalpha = 0.5\nkd = 0.5\n'
          '[incidence]\ntheta_i_deg = [0]\npaths = 4096\n[simulation]\nsensor_resolution = 5\n')
CORES = len(os.sched_getaffinity(0))
BAD = [
    ("garbage", "not a scheduler address: give PROTOCOL://HOST:PORT (tcp://host:8786), HOST:PORT or local:N"),
    ("tcp://", "not a scheduler address"),
    ("host:port", "not a scheduler address"),
    ("", "give a scheduler address (tcp://host:8786) or local:N"),
    ("local:0", f"local:N starts N worker processes: N must be an integer from 1 to {CORES} (the cores here)"),
    (f"local:{CORES + 1}", f"N must be an integer from 1 to {CORES} (the cores here)"),
    ("local:1000", f"N must be an integer from 1 to {CORES} (the cores here)"),
    ("local:x", "N must be an integer"),
]


def _files(folder, command):
    config = folder / ("s.toml" if command == "sweep" else "c.toml")
    config.write_text(CONFIG + ("[sweep]\nalpha = [0.2, 0.5]\n" if command == "sweep" else ""))
    return config, folder / "out.h5"


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("address, message", BAD, ids=[b[0] or "empty" for b in BAD])
def test_a_bad_dask_address_is_one_line_before_compiling(tmp_path, capsys, command, address, message):
    config, out = _files(tmp_path, command)
    assert main([command, str(config), "-o", str(out), "-q", "--dask", address]) == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("vcavity: error: ")]
    assert len(errors) == 1 and errors[0].startswith(f"vcavity: error: --dask = {address!r}: ")
    assert message in errors[0] and errors[0].count("--dask") == 1
    assert "kernel ready" not in err and "Traceback" not in err
    assert not out.exists()


def test_no_scheduler_at_the_address_is_one_line(tmp_path, capsys):
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    config, out = _files(tmp_path, "sweep")
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        assert main(["sweep", str(config), "-o", str(out), "-q", "--dask", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("vcavity: error: ")]
    assert errors == [line for line in err.splitlines() if line.strip()] and len(errors) == 1
    assert errors[0].startswith("vcavity: error: --dask = 'tcp://127.0.0.1:1': cannot use it (")
    assert not out.exists()
