"""Reading tables needs no JIT, and a read-only install works (vcavity/_numba/jit.py, README).

The read-only tests copy the package into a temporary folder that the child processes
cannot write, give them an unwritable HOME and no NUMBA_CACHE_DIR, and run the public
commands there. vcavity cannot make its per-user cache folder in that HOME, and must fall
back to a private folder in TMPDIR, or, when TMPDIR is unwritable too, run uncached with
a one-line note. Root ignores permission bits, so as root the children run as ``nobody``;
where ``nobody`` cannot reach the interpreter (a Python installed under /root, as on
the CI machine), the children run as root in a private mount namespace in which the
package copy, HOME and the unwritable TMPDIR are read-only bind mounts (``unshare -m``),
which refuse writes even to root. The ``run`` steps compile a kernel cold: the mirror-facet
variant, the cheapest to compile (about 4 s of CPU; the interfaced-Lambertian one also
compiles the Fresnel helpers), since what is tested is where the compiled code goes.
"""

import os
import pwd
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from vcavity.io.schema import FORMAT_VERSION

from vcavity.io.table import write_table
from tests.io.tables import analog_table
from vcavity.sensor.grid import EqualAreaSensor

REPO = Path(__file__).resolve().parents[2]
V1_TABLE = REPO / "tests" / "io" / "data" / "table_v1.h5"
NOTE = "vcavity: note: no writable Numba cache directory"
TINY_CONFIG = """\
[material]
distribution = "beckmann"
alpha = 0.5
facet = "mirror"

[incidence]
theta_i_deg = [40]
paths = 20000

[simulation]
sensor_resolution = 9
"""
OPEN_TABLE = ("import sys, vcavity; t = vcavity.open_table(sys.argv[1]); print(t.format_version); "
              "print(vcavity.__file__); print('numba imported:', 'numba' in sys.modules)")


def _write_small_table(path):
    """A consistent format-2 table from synthetic counts (no simulation)."""
    sensor = EqualAreaSensor(5)
    counts = np.zeros((1, 2, sensor.n_cells), dtype=np.int64)
    counts[0, 1] = np.arange(sensor.n_cells)  # 300 single-bounce exits
    counts[0, 0] = counts[0, 1] + 1  # plus 25 of higher order
    write_table(path, analog_table(theta_i=[0.5], phi_i=[0.0], order=[0, 1], counts=counts, paths=[400],
                absorbed_paths=[75], truncated_paths=[0], degenerate_paths=[0],
                max_bounces_seen=[3], sensor=sensor,
                material={"distribution": "beckmann", "facet": "interfaced_lambertian",
                          "alpha_x": 0.5, "alpha_y": 0.5, "kd": 0.5, "eta": 1.5},
                config={}, seed=1, block_size=4096, max_bounces=100))


# ------------------------------------------------------------------ no Numba for reading
# Child-process prelude: remember which vcavity lines first import Numba, if any.
NUMBA_SPY = """\
import sys, traceback
numba_importer = None
class _NumbaSpy:
    def find_spec(self, name, path=None, target=None):
        global numba_importer
        if name == "numba" and numba_importer is None:
            numba_importer = [f"{f.filename}:{f.lineno}" for f in traceback.extract_stack()
                              if "vcavity" in f.filename]
        return None
sys.meta_path.insert(0, _NumbaSpy())
"""
REPORT_NUMBA = "print('numba imported by:', numba_importer if 'numba' in sys.modules else None)\n"


def _run_with_numba_spy(code, argument, cwd):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, "-c", NUMBA_SPY + code + REPORT_NUMBA, str(argument)],
                            cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip().splitlines()


@pytest.mark.parametrize("which", ["fresh", "v1"])
def test_open_table_imports_no_numba(tmp_path, which):
    path = V1_TABLE if which == "v1" else tmp_path / "t.h5"
    if which == "fresh":
        _write_small_table(path)
    code = ("import vcavity, vcavity.io.summary\n"  # io/summary.py formats what `info` prints
            "print(vcavity.open_table(sys.argv[1]).format_version)\n")
    lines = _run_with_numba_spy(code, path, tmp_path)
    assert lines == ["1" if which == "v1" else str(FORMAT_VERSION), "numba imported by: None"]


def test_info_imports_no_numba(tmp_path):
    _write_small_table(tmp_path / "t.h5")
    # the console entry ends with os._exit: report there, before the process ends
    code = ("import os, runpy\n"
            "sys.argv = ['vcavity', 'info', sys.argv[1]]\n"
            "real_exit = os._exit\n"
            "def reporting_exit(code):\n"
            "    print('status', code)\n" + "    " + REPORT_NUMBA +
            "    sys.stdout.flush()\n    real_exit(code)\n"
            "os._exit = reporting_exit\n"
            "runpy.run_module('vcavity', run_name='__main__', alter_sys=True)\n")
    lines = _run_with_numba_spy(code, tmp_path / "t.h5", tmp_path)
    assert lines[-2:] == ["status 0", "numba imported by: None"], "\n".join(lines)


# ------------------------------------------------------------------- read-only install
def _child_user():
    """(uid, gid) of ``nobody`` when we are root (root ignores permission bits), else None."""
    if os.geteuid() != 0:
        return None
    try:
        entry = pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("running as root, and there is no user 'nobody' to run the children as")
    return entry.pw_uid, entry.pw_gid


def _not_world_traversable(path):
    """The first directory on the way to ``path`` that others cannot enter, or None."""
    for directory in [Path(path), *Path(path).parents]:
        if directory.is_dir() and not directory.stat().st_mode & stat.S_IXOTH:
            return directory
    return None


def _run(sandbox, args, tmpdir):
    """Run ``python args`` as the sandbox's user, in its writable folder."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "TMPDIR", "TEMP", "TMP",
                          "PYTHONPATH", "MPLCONFIGDIR")}
    kept = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
            if p and not Path(p).resolve().is_relative_to(REPO)]  # never the work tree
    env.update(HOME=str(sandbox.home), TMPDIR=str(tmpdir),
               PYTHONPATH=os.pathsep.join([str(sandbox.site), *kept]))
    options = {}
    if sandbox.user is not None:
        options = dict(user=sandbox.user[0], group=sandbox.user[1], extra_groups=[])
    command = _read_only_mounts([sys.executable, *args], sandbox.read_only)
    return subprocess.run(command, cwd=sandbox.out, env=env, capture_output=True,
                          text=True, timeout=600, **options)


def _read_only_mounts(command, folders):
    """``command`` run in a private mount namespace where ``folders`` are read-only."""
    if not folders:
        return command
    script = "set -e\n" + "".join(f'mount --bind "{f}" "{f}"\nmount -o remount,bind,ro "{f}"\n'
                                   for f in folders) + 'exec "$@"\n'
    return ["unshare", "--mount", "--propagation", "private", "sh", "-c", script, "sh", *command]


@pytest.fixture(scope="module")
def sandbox():
    user = _child_user()
    root = Path(tempfile.mkdtemp(prefix="vcavity-readonly-"))
    try:
        os.chmod(root, 0o755)  # mkdtemp makes 0700: the child user must get in
        box = SimpleNamespace(user=user, root=root, site=root / "site", home=root / "home",
                              out=root / "out", tmp=root / "tmp", tmp_unwritable=root / "tmp-ro",
                              runs={}, read_only=())
        for folder in (box.site, box.home, box.out, box.tmp, box.tmp_unwritable):
            folder.mkdir(mode=0o755)
        shutil.copytree(REPO / "vcavity", box.site / "vcavity",
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        _write_small_table(box.out / "table.h5")
        (box.out / "tiny.toml").write_text(TINY_CONFIG)
        for path in (box.out / "table.h5", box.out / "tiny.toml"):
            os.chmod(path, 0o644)
        if user is not None:
            for folder in (box.out, box.tmp):  # the only places the child may write
                os.chown(folder, *user)
        for directory, _, files in os.walk(box.site, topdown=False):  # chmod -R a-w
            for name in files:
                os.chmod(Path(directory) / name, 0o444)
            os.chmod(directory, 0o555)
        for folder in (box.home, box.tmp_unwritable):
            os.chmod(folder, 0o555)
        if user is not None:
            blocked = [b for b in map(_not_world_traversable,
                                      (root, sys.executable, os.path.realpath(sys.executable))) if b]
            if blocked:  # nobody cannot start this Python: root behind read-only mounts instead
                box.user = None
                box.read_only = (box.site, box.home, box.tmp_unwritable)
                for folder in (box.out, box.tmp):
                    os.chown(folder, 0, 0)
                probe = _run(box, ["-c", "import os; print(os.access(os.environ['HOME'], os.W_OK))"], box.tmp)
                if probe.returncode != 0 or probe.stdout.strip() != "False":
                    last = (probe.stderr.strip().splitlines() or [probe.stdout.strip() or "?"])[-1]
                    pytest.skip(f"running as root; nobody cannot reach {blocked[0]} (not "
                                f"world-executable) and read-only bind mounts are unavailable: {last}")
            probe = _run(box, ["-c", "import numpy, h5py, numba"], box.tmp)
            if probe.returncode != 0:
                last = (probe.stderr.strip().splitlines() or ["?"])[-1]
                pytest.skip(f"{sys.executable} cannot import numpy, h5py, numba as nobody: {last}")
        yield box
    finally:
        for directory, _, _ in os.walk(root):
            os.chmod(directory, 0o755)
        shutil.rmtree(root, ignore_errors=True)


def _assert_clean(result, statuses=(0,)):
    assert result.returncode in statuses, (result.returncode, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr, result.stderr
    assert result.stderr.count(NOTE) <= 1, result.stderr


def _vcavity_run(sandbox, case):
    """``vcavity run`` once per temporary-directory case (writable / unwritable)."""
    if case not in sandbox.runs:
        tmpdir = sandbox.tmp if case == "writable tmp" else sandbox.tmp_unwritable
        output = sandbox.out / f"x-{case.split()[0]}.h5"
        sandbox.runs[case] = (output, _run(sandbox, ["-m", "vcavity", "run", "tiny.toml", "-o",
                                                     str(output), "-q"], tmpdir))
    return sandbox.runs[case]


CASES = ["writable tmp", "unwritable tmp"]


def test_sandbox_is_read_only_and_used(sandbox):
    code = ("import os, sys, importlib.util, vcavity\n"
            "print(vcavity.__file__)\n"
            "print(importlib.util.find_spec('vcavity.__main__').origin)\n"
            "print(os.access(os.path.dirname(vcavity.__file__), os.W_OK), "
            "os.access(os.environ['HOME'], os.W_OK))\n")
    result = _run(sandbox, ["-c", code], sandbox.tmp)
    _assert_clean(result)
    package, main, writable = result.stdout.splitlines()
    assert Path(package) == sandbox.site / "vcavity" / "__init__.py"
    assert Path(main) == sandbox.site / "vcavity" / "__main__.py"
    assert writable == "False False"  # neither the package nor HOME can be written


@pytest.mark.parametrize("case", CASES)
def test_open_table(sandbox, case):
    tmpdir = sandbox.tmp if case == "writable tmp" else sandbox.tmp_unwritable
    result = _run(sandbox, ["-c", OPEN_TABLE, str(sandbox.out / "table.h5")], tmpdir)
    _assert_clean(result)
    version, package, numba = result.stdout.splitlines()
    assert version == str(FORMAT_VERSION) and Path(package) == sandbox.site / "vcavity" / "__init__.py"
    assert numba == "numba imported: False"
    assert NOTE not in result.stderr  # nothing cached, nothing to say


@pytest.mark.parametrize("case", CASES)
def test_info(sandbox, case):
    tmpdir = sandbox.tmp if case == "writable tmp" else sandbox.tmp_unwritable
    result = _run(sandbox, ["-m", "vcavity", "info", str(sandbox.out / "table.h5")], tmpdir)
    _assert_clean(result)
    assert f"format v{FORMAT_VERSION}" in result.stdout and "albedo f1" in result.stdout


# each case compiles the kernel in a fresh cache (~15 s): the fallback case runs in the slow suite
@pytest.mark.parametrize("case", ["writable tmp", pytest.param("unwritable tmp", marks=pytest.mark.slow)])
def test_run_compiles_and_writes_a_table(sandbox, case):
    output, result = _vcavity_run(sandbox, case)
    _assert_clean(result)
    assert output.is_file() and f"wrote {output}" in result.stdout
    uid = sandbox.user[0] if sandbox.user is not None else os.getuid()
    private_cache = sandbox.tmp / f"vcavity-numba-cache-{uid}"
    if case == "writable tmp":  # no per-user cache folder in that HOME: the private folder is used
        assert NOTE not in result.stderr
        assert private_cache.is_dir() and any(private_cache.rglob("*.nbi")), result.stderr
        assert stat.S_IMODE(private_cache.stat().st_mode) == 0o700
    else:  # nowhere to cache: compiled in this process, said once
        assert result.stderr.count(NOTE) == 1, result.stderr


@pytest.mark.slow  # ~20 s: runs in CI's slow suite (keeps the default suite under 10 min)
def test_compare_on_the_table_run_produced(sandbox):
    output, run = _vcavity_run(sandbox, "writable tmp")
    assert run.returncode == 0, run.stderr
    result = _run(sandbox, ["-m", "vcavity", "compare", str(output)], sandbox.tmp)
    _assert_clean(result, statuses=(0, 1))  # pass or fail, never bad input (2) or a crash
    assert "result:" in result.stdout
