"""The README as a newcomer runs it, top to bottom (issue 38 item 3).

Every fenced block of README.md is taken in order, in a fresh folder holding what a clone
has that the commands use (``runs/``, ``scripts/``): each shell line is run (``vcavity``
as ``python -m vcavity``, ``python3`` as this interpreter), each Python snippet as written
in a process of its own, the TOML example as a run config. So every file a command or
snippet reads must have been made by an earlier step. Budgets only are substituted: every
``run``, ``sweep`` and ``scripts/fig7.py`` gets ``--paths`` :data:`SMALL_PATHS` (replacing
the README's value where it gives one). Left out: ``pip install`` (the test runs from
this checkout), ``python3 -m pytest`` (the suite itself), and the Mitsuba render where
Mitsuba is not installed (the README says it needs ``vcavity[render]``). A file a line's comment says
it writes ("writes F", "-> F") must be there afterwards. Exit status 0 everywhere, except that ``compare`` may say FAIL with 1 (its documented "exit 0/1": the
``--model smith`` line compares a V-cavity table with another microsurface's model).

The fast tests check what the README says against the CLI: the estimators it names are
the ones ``run --help`` lists, and ``warmup --all`` is every variant of the distributions,
facet variants and Smith-walk distributions it names (``--all --list`` compiles nothing).
"""

import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
SMALL_PATHS = "3000"
BUDGETED = {"run", "sweep", "scripts/fig7.py"}


def blocks():
    """``(language, text)`` of every fenced block, in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(\w*)\n(.*?)^```", README, re.S | re.M)]


def _environment():
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return env


def _cli(*args, cwd=ROOT, timeout=600):
    return subprocess.run([sys.executable, "-m", "vcavity", *args], cwd=cwd, env=_environment(),
                          capture_output=True, text=True, timeout=timeout)


def _with_budget(argv):
    """``argv`` with ``--paths SMALL_PATHS`` (replacing a given value)."""
    argv = list(argv)
    if "--paths" in argv:
        argv[argv.index("--paths") + 1] = SMALL_PATHS
    else:
        argv += ["--paths", SMALL_PATHS]
    return argv


def _commands(text):
    """The argv lists of a shell block's lines, ``&&`` chains split; None for a part left out."""
    for line in text.splitlines():
        tokens = shlex.split(line, comments=True)
        while tokens:
            part = tokens[:tokens.index("&&")] if "&&" in tokens else tokens
            tokens = tokens[len(part) + 1:]
            yield line, part


def _argv(part):
    """What this test runs for one command of the README, or None to leave it out."""
    program, rest = part[0], part[1:]
    if program == "vcavity":
        argv = [sys.executable, "-m", "vcavity", *rest]
        budget = rest[0] in BUDGETED
    elif program in ("python", "python3"):
        if rest[:2] in (["-m", "pip"], ["-m", "pytest"]):
            return None
        if rest[0] == "scripts/render_mitsuba.py" and importlib.util.find_spec("mitsuba") is None:
            return None
        argv = [sys.executable, *rest]
        budget = rest[0] in BUDGETED
    else:
        raise AssertionError(f"README command not understood by this test: {part}")
    return _with_budget(argv) if budget else argv


def test_the_estimators_the_readme_names_are_those_run_help_lists():
    named = set(re.findall(r'estimator = "([a-z0-9-]+)"', README))
    assert {"analog", "exact-f1", "paper", "exact"} <= named, named
    listed = re.search(r"--estimator \{([a-z0-9,-]+)\}", _cli("run", "--help").stdout).group(1).split(",")
    assert set(listed) == named, (listed, named)


def test_warmup_all_is_every_variant_the_readme_names():
    """Distributions and facets from the README's config example, the three
    interfaced-Lambertian variants (kd = 0, eta = 1, full) and the Smith walk's distributions
    from its comment: 5 x 5 V-groove + 4 x 5 Smith variants."""
    distributions = re.search(r'^distribution = "\w+" +# ([a-z_ |]+)$', README, re.M).group(1).split(" | ")
    smith = re.search(r"Smith's random walk \(Heitz et al\.\n\s*# 2016; ([a-z_, ]+);", README).group(1).split(", ")
    facets = ["interfaced_lambertian (specular dielectric)", "interfaced_lambertian (lambertian)",
              "interfaced_lambertian", "mirror", "conductor"]
    listing = _cli("warmup", "--all", "--list")
    assert listing.returncode == 0, listing.stderr
    lines = {line.strip() for line in listing.stdout.splitlines() if " x " in line}
    expected = {f"{d} x {f}" for d in distributions for f in facets}
    expected |= {f"{d} x {f} (smith walk)" for d in smith for f in facets}
    assert lines == expected, (sorted(lines - expected), sorted(expected - lines))
    assert len(expected) == 45


@pytest.mark.slow
def test_every_command_and_snippet_of_the_readme_runs_in_order(tmp_path):
    for folder in ("runs", "scripts"):
        shutil.copytree(ROOT / folder, tmp_path / folder)
    done = []
    for language, text in blocks():
        if language in ("sh", "bash"):
            for line, part in _commands(text):
                argv = _argv(part)
                if argv is None:
                    continue
                result = subprocess.run(argv, cwd=tmp_path, env=_environment(), capture_output=True, text=True,
                                        timeout=900)
                allowed = (0, 1) if part[:2] == ["vcavity", "compare"] else (0,)
                assert result.returncode in allowed, (line, result.returncode, result.stdout[-2000:],
                                                      result.stderr[-2000:])
                if part[:2] == ["vcavity", "compare"] and "--help" not in part:
                    assert "result: " in result.stdout, (line, result.stdout[-2000:])
                # a file the line's comment says it writes ("writes F", "-> F") is there
                for name in re.findall(r"(?:writes|->) ([\w./-]+\.(?:h5|png|pdf))", line.partition("#")[2]):
                    assert (tmp_path / name).is_file(), (line, name)
                done.append(line)
        elif language == "python":
            result = subprocess.run([sys.executable, "-c", text], cwd=tmp_path, env=_environment(),
                                    capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, (text, result.stderr[-3000:])
            done.append(text.splitlines()[0])
        elif language == "toml":
            config = tmp_path / "readme_example.toml"
            config.write_text(text)
            result = subprocess.run(_with_budget([sys.executable, "-m", "vcavity", "run", str(config), "-q"]),
                                    cwd=tmp_path, env=_environment(), capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, (result.stderr[-2000:])
            done.append("the TOML example")
        else:
            raise AssertionError(f"README block of language {language!r} not understood by this test")
    assert len(done) > 30, done
