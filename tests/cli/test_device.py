"""``--device`` and ``simulation.device`` (docs/gpu.md): the walk on a GPU through numba-cuda.

- Refusals: ``device = "cuda"`` with an estimator that traces no path, with a weighted walk
  (the paper estimator's, also with ``--dask``), without numba-cuda (a stand-in makes its import
  fail) and without a CUDA device or driver is one line naming the field as written
  (``--device`` when the flag gave the value, else ``simulation.device``), exit status 2,
  before anything is compiled or written (no file appears), for ``run`` and ``sweep``.
- Under numba's CUDA simulator (a child process, tests/cli/device_sim_child.py: numba
  reads ``NUMBA_ENABLE_CUDASIM`` at import), where the kernel's device functions are the
  CPU's own compiled code on the same streams, ``vcavity run --device cuda`` writes the
  table of ``--device cpu`` exactly, for any chunking and across a Ctrl-C and
  ``--resume``; the table records the device and ``vcavity info`` prints it.
- ``gpu`` (skipped without a device): a run on a real GPU conserves its paths and names
  the GPU, the CUDA driver and the runtime.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vcavity import open_table
from vcavity.cli import main

from tests.cli.device_support import CONFIG, HAVE_NUMBA_CUDA, NO_DEVICE, NOT_INSTALLED

needs_numba_cuda = pytest.mark.skipif(not HAVE_NUMBA_CUDA,
                                      reason="numba-cuda is not installed (pip install 'vcavity[cuda]')")

SWEEP = CONFIG + "[sweep]\nalpha = [0.3, 0.6]\n"


def _write(tmp_path, text, simulation="", name="run.toml"):
    path = tmp_path / name
    path.write_text(text.format(simulation=simulation))
    return path


def _refused(tmp_path, capsys, argv) -> str:
    """Run ``vcavity ARGV``: exit 2, one line on stderr, nothing on stdout, no file written."""
    before = sorted(tmp_path.iterdir())
    status = main(argv)
    captured = capsys.readouterr()
    assert status == 2, captured.err
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: "), captured.err
    assert sorted(tmp_path.iterdir()) == before  # no table, no checkpoint, no temporary
    return lines[0][len("vcavity: error: "):]


WEIGHTED = "the paper estimator runs on the CPU only: its walk is weighted"


@pytest.mark.parametrize("flags, simulation, words", [
    (["--device", "cuda", "--estimator", "paper"], "", f"--device = 'cuda': {WEIGHTED}"),
    (["--estimator", "paper"], 'device = "cuda"\n', f"simulation.device = 'cuda': {WEIGHTED}"),
    ([], 'device = "cuda"\nestimator = "paper"\n', f"simulation.device = 'cuda': {WEIGHTED}"),
    (["--device", "cuda", "--estimator", "paper", "--dask", "local:1"], "", f"--device = 'cuda': {WEIGHTED}"),
], ids=["weighted-flag", "weighted-config", "weighted-config-estimator", "weighted-dask"])
def test_a_refused_device_is_one_line_and_writes_nothing(tmp_path, capsys, flags, simulation, words):
    config = _write(tmp_path, CONFIG, simulation)
    line = _refused(tmp_path, capsys, ["run", str(config), "-o", str(tmp_path / "t.h5"), "-q", *flags])
    assert line.startswith(words), line


@pytest.mark.parametrize("flag", [True, False], ids=["flag", "config"])
def test_cuda_without_numba_cuda_is_refused(tmp_path, capsys, no_numba_cuda, flag):
    config = _write(tmp_path, CONFIG, "" if flag else 'device = "cuda"\n')
    line = _refused(tmp_path, capsys, ["run", str(config), "-o", str(tmp_path / "t.h5"), "-q"]
                    + (["--device", "cuda"] if flag else []))
    assert line == f"{'--device' if flag else 'simulation.device'} = 'cuda': {NOT_INSTALLED}"


def test_cuda_without_a_device_is_refused(tmp_path, capsys, no_gpu):
    config = _write(tmp_path, CONFIG)
    line = _refused(tmp_path, capsys, ["run", str(config), "-o", str(tmp_path / "t.h5"), "-q", "--device", "cuda"])
    assert line.startswith(f"--device = 'cuda': {NO_DEVICE}"), line


def test_a_sweep_makes_the_same_refusals(tmp_path, capsys, no_numba_cuda):
    spec = _write(tmp_path, SWEEP, name="sweep.toml")
    out = str(tmp_path / "s.h5")
    line = _refused(tmp_path, capsys, ["sweep", str(spec), "-o", out, "-q", "--device", "cuda", "--estimator", "paper"])
    assert line.startswith(f"--device = 'cuda': {WEIGHTED}"), line
    assert _refused(tmp_path, capsys, ["sweep", str(spec), "-o", out, "-q", "--device", "cuda"]) == \
        f"--device = 'cuda': {NOT_INSTALLED}"


def test_a_cpu_table_says_so_and_a_table_without_the_attribute_reads_as_cpu():
    """Tables before the device attribute (tests/io/data) are CPU tables."""
    from vcavity.io.summary import format_summary

    old = open_table(Path(__file__).parents[1] / "io" / "data" / "table_v2.h5")
    assert "device" not in old.attrs and old.device == "cpu"
    assert "device: cpu" in format_summary(old, verbose=True).splitlines()


#: The table's datasets that the device must not change (all but the times, which are attributes).
FIELDS = ("counts", "brdf", "brdf_stderr", "albedo", "absorbed", "truncated", "degenerate", "paths",
          "max_bounces_seen", "unbinned_paths", "relative_error")


@needs_numba_cuda
def test_a_simulated_cuda_run_writes_the_cpu_runs_table(tmp_path):
    config = _write(tmp_path, CONFIG)
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    out = subprocess.run([sys.executable, str(Path(__file__).with_name("device_sim_child.py")), str(config),
                          str(tmp_path)], env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-4000:]
    result = json.loads(out.stdout.splitlines()[-1])
    assert result["statuses"] == {"cpu": 0, "cuda": 0, "chunked": 0, "interrupted": 130, "resumed": 0,
                                  "info": 0}, out.stderr[-4000:]
    cpu = open_table(tmp_path / "cpu.h5")
    assert cpu.device == "cpu" and "device_name" not in cpu.attrs and "device" not in cpu.config["simulation"]
    assert cpu.counts.sum() > 0 and (cpu.counts[:, 1:].sum(axis=2) > 0).all()
    for name in ("cuda.h5", "cuda_chunked.h5", "cuda_resumed.h5"):
        table = open_table(tmp_path / name)
        for field in FIELDS:
            np.testing.assert_array_equal(getattr(table, field), getattr(cpu, field), err_msg=f"{name}: {field}")
        assert table.device == "cuda" and table.config["simulation"]["device"] == "cuda"
        assert {key: table.attrs[key] for key in ("device_name", "cuda_driver_version", "cuda_runtime_version")} \
            == dict.fromkeys(("device_name", "cuda_driver_version", "cuda_runtime_version"), "simulator")
    assert not (tmp_path / "cuda_resumed.h5.checkpoint").exists()
    assert "device: cuda (numba's CUDA simulator)" in result["info"].splitlines()


@needs_numba_cuda
@pytest.mark.gpu
def test_a_gpu_run_records_its_device(tmp_path):
    """On a real device (skipped without one): the run conserves every path, and the table
    names the GPU and the CUDA versions (its counts agree with the CPU's in distribution
    only: tests/kernels/test_cuda_loop.py tests that)."""
    from numba import cuda

    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1" or not cuda.is_available():
        pytest.skip("no CUDA device")
    config = _write(tmp_path, CONFIG)
    assert main(["run", str(config), "-o", str(tmp_path / "gpu.h5"), "-q", "--device", "cuda"]) == 0
    table = open_table(tmp_path / "gpu.h5")
    assert table.device == "cuda" and table.attrs["device_name"] not in ("", "simulator")
    for key in ("cuda_driver_version", "cuda_runtime_version"):
        assert all(part.isdigit() for part in table.attrs[key].split(".")), table.attrs[key]
    lost = table.absorbed + table.truncated + table.degenerate
    np.testing.assert_allclose(table.counts[:, 0].sum(axis=1) / table.paths + lost, 1.0, rtol=0, atol=1e-12)
    from vcavity.io.summary import format_summary

    assert any(line.startswith("device: cuda (") and "CUDA driver" in line
               for line in format_summary(table, verbose=True).splitlines())
