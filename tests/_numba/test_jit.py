"""Compiled code never lands inside the install (vcavity/_numba/jit.py, README, issue 21 item 6).

Numba's default is the ``__pycache__`` folders beside the sources: for a regular install
``site-packages/vcavity/*/__pycache__``, which ``pip uninstall`` leaves behind as a
``vcavity`` namespace folder shadowing the next install. The children below import Numba
first (the import order must not matter), compile one of vcavity's ``cache=True``
functions and one of another package's, from a package copy laid out as a regular
install (``site/vcavity``) or as a source checkout (an editable install), and the test
looks where the files went: vcavity's into the per-user folder (or ``NUMBA_CACHE_DIR``),
the other package's where Numba alone puts them, nothing into the vcavity copy.
"""

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from vcavity._numba import jit
from vcavity._version import __version__

REPO = Path(__file__).resolve().parents[2]
OTHER = "import numba\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n"
CHILD = """\
import sys
import numba
before = numba.config.CACHE_DIR
from vcavity._numba import jit
from vcavity.sensor.binning import square_to_hemisphere
square_to_hemisphere(0.25, -0.5)
import other
other.twice(1.5)
print(jit.CACHE_LOCATION)
print(repr(before), repr(numba.config.CACHE_DIR))
"""


def _cache_files(folder: Path) -> list[Path]:
    return sorted(p for pattern in ("*.nbi", "*.nbc") for p in folder.rglob(pattern))


@pytest.mark.parametrize("layout, variable", [("regular install", None), ("source checkout", "XDG_CACHE_HOME"),
                                              ("regular install", "NUMBA_CACHE_DIR")])
def test_compiled_code_goes_to_the_cache_folder_not_the_package(tmp_path, layout, variable):
    root = tmp_path / ("site" if layout == "regular install" else "checkout")
    shutil.copytree(REPO / "vcavity", root / "vcavity", ignore=shutil.ignore_patterns("__pycache__"))
    if layout == "source checkout":
        shutil.copy(REPO / "pyproject.toml", root)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "other.py").write_text(OTHER)
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "PYTHONPATH")}
    env.update(HOME=str(home), PYTHONPATH=os.pathsep.join([str(root), str(tmp_path / "other")]))
    if variable is not None:
        env[variable] = str(tmp_path / "chosen")
    result = subprocess.run([sys.executable, "-c", CHILD], cwd=tmp_path, env=env, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    location, config = result.stdout.strip().splitlines()

    expected = {None: home / ".cache" / "vcavity" / __version__ / "numba",
                "XDG_CACHE_HOME": tmp_path / "chosen" / "vcavity" / __version__ / "numba",
                "NUMBA_CACHE_DIR": tmp_path / "chosen"}[variable]
    assert Path(location) == expected
    assert _cache_files(root / "vcavity") == []  # nothing inside the package
    ours = _cache_files(expected)
    assert any(p.name.startswith("binning.square_to_hemisphere") for p in ours), ours
    # the other package's function is cached where Numba alone puts it (beside its source),
    # except that NUMBA_CACHE_DIR is Numba's own setting and applies to it too
    theirs = _cache_files(tmp_path / "other")
    assert any(p.name.startswith("other.twice") for p in theirs) == (variable != "NUMBA_CACHE_DIR"), theirs
    assert not any("twice" in p.name for p in ours) or variable == "NUMBA_CACHE_DIR"
    chosen = repr(str(tmp_path / "chosen")) if variable == "NUMBA_CACHE_DIR" else "''"
    assert config == f"{chosen} {chosen}"  # Numba's setting as the user left it


@pytest.mark.parametrize("platform, environ, parts", [
    ("linux", {"HOME": "/h"}, ("/h", ".cache")),
    ("linux", {"HOME": "/h", "XDG_CACHE_HOME": "/x"}, ("/x",)),
    ("linux", {"HOME": "/h", "XDG_CACHE_HOME": "relative"}, ("/h", ".cache")),  # XDG: ignored
    ("darwin", {"HOME": "/h"}, ("/h", "Library", "Caches")),
    ("win32", {"HOME": "/h", "LOCALAPPDATA": "C:/L"}, ("C:/L",)),
])
def test_user_cache_dir_follows_the_platform_rules(platform, environ, parts):
    tail = ("vcavity", "Cache") if platform == "win32" else ("vcavity",)
    assert jit.user_cache_dir(environ, platform) == os.path.join(*parts, *tail, __version__, "numba")


def test_windows_without_local_app_data_has_no_user_cache():
    assert jit.user_cache_dir({"HOME": "/h"}, "win32") is None


def _numba_njit_with_cache(path: Path) -> list[int]:
    """Lines of ``path`` that decorate with Numba's own njit and ``cache=True``."""
    tree = ast.parse(path.read_text())
    from_numba = {alias.asname or alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                  and node.module == "numba" for alias in node.names if alias.name in ("njit", "jit")}
    lines = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        numba_own = (isinstance(f, ast.Attribute) and f.attr in ("njit", "jit") and isinstance(f.value, ast.Name)
                     and f.value.id == "numba") or (isinstance(f, ast.Name) and f.id in from_numba)
        cached = any(k.arg == "cache" and isinstance(k.value, ast.Constant) and k.value.value for k in node.keywords)
        if numba_own and cached:
            lines.append(node.lineno)
    return lines


def test_every_cached_function_uses_vcavitys_njit():
    """Package, tests and scripts alike: cache=True only through vcavity._numba.jit.njit,
    so no compiled file lands in a source tree or an install."""
    offenders = {str(p.relative_to(REPO)): lines for folder in ("vcavity", "tests", "scripts")
                 for p in sorted((REPO / folder).rglob("*.py")) if (lines := _numba_njit_with_cache(p))}
    assert offenders == {}


NAMED = """\
from vcavity._numba import jit
print(jit.CACHE_LOCATION)
print(jit.NAMED_CACHE_REFUSED)
"""


def _child_env(tmp_path, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "TMPDIR")}
    env.update(HOME=str(tmp_path / "home"), PYTHONPATH=str(REPO), **extra)
    return env


def test_an_unusable_named_cache_is_a_note_for_runs_and_an_error_for_warmup(tmp_path):
    """NUMBA_CACHE_DIR naming a file: a run's process says so in one line and caches in the
    per-user folder; warmup refuses (exit 2, one line) rather than fill a folder the runs
    that name this cache never read (issue 38)."""
    (tmp_path / "home").mkdir()
    named = tmp_path / "a-file"
    named.write_text("not a folder")
    env = _child_env(tmp_path, NUMBA_CACHE_DIR=str(named))
    child = subprocess.run([sys.executable, "-c", NAMED], env=env, capture_output=True, text=True, timeout=120)
    assert child.returncode == 0, child.stderr
    location, refused = child.stdout.strip().splitlines()
    assert Path(location) == tmp_path / "home" / ".cache" / "vcavity" / __version__ / "numba"
    assert refused.startswith(f"NUMBA_CACHE_DIR = {str(named)!r}: cannot hold files (")
    note = child.stderr.strip().splitlines()
    assert len(note) == 1 and note[0] == f"vcavity: note: {refused}; compiled code goes to {location} instead"
    warmup = subprocess.run([sys.executable, "-m", "vcavity", "warmup", "--distribution", "ggx", "--facet", "mirror"],
                            env=env, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert warmup.returncode == 2, warmup.stderr
    lines = [line for line in warmup.stderr.splitlines() if not line.startswith("vcavity: note: ")]
    assert len(lines) == 1 and lines[0].startswith(f"vcavity: error: {refused}; warmup fills the cache"), warmup.stderr
    assert not (tmp_path / "home" / ".cache" / "vcavity" / __version__ / "numba").exists() or not any(
        (tmp_path / "home" / ".cache").rglob("*.nbi"))  # nothing compiled


def test_no_temporary_cache_folder_unless_it_is_used(tmp_path):
    """The private temporary folder is the last resort: with a usable NUMBA_CACHE_DIR (or a
    writable home) it is not created (issue 38: every process used to make an empty one)."""
    (tmp_path / "home").mkdir()
    (tmp_path / "tmp").mkdir()
    for extra in ({"NUMBA_CACHE_DIR": str(tmp_path / "chosen")}, {}):
        env = _child_env(tmp_path, TMPDIR=str(tmp_path / "tmp"), **extra)
        child = subprocess.run([sys.executable, "-c", NAMED], env=env, capture_output=True, text=True, timeout=120)
        assert child.returncode == 0 and child.stderr == "", child.stderr
        assert child.stdout.splitlines()[1] == ""  # nothing refused
        assert list((tmp_path / "tmp").iterdir()) == [], extra
