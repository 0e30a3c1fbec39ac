"""``vcavity warmup`` (vcavity/cli/warmup.py, vcavity/simulate/warmup.py) and the line ``vcavity run``
prints while it compiles (issue 21 items 3 and 4).

The selection is checked against the kernels' own variant list and the registries; the
notice against a stand-in compile of known length; the cross-process cache (two warmups
at once into one fresh folder, then a third and a run that only load) in the slow suite.
"""

import io
import os
import subprocess
import sys
import time

import pytest
from numba.core import event

from vcavity.cli import main
from vcavity.facet import registry as facets
from vcavity.kernels.trace import variants as kernel_variants
from vcavity.microfacet import registry as distributions
from vcavity.simulate.warmup import MODELS, CompileNotice, Variant, compile_variant, variants


def test_help_says_where_the_cache_is_and_what_is_safe(capsys):
    with pytest.raises(SystemExit) as exit:
        main(["warmup", "--help"])
    out = " ".join(capsys.readouterr().out.split())  # as read, not as wrapped
    assert exit.value.code == 0
    for fact in ("NUMBA_CACHE_DIR", "~/.cache/vcavity/<version>/numba", "--all", "several warmups at once",
                 "Ctrl-C", "Dask", "--list", "v-cavity, smith"):
        assert fact in out, fact


def test_list_of_all_follows_the_kernels_and_the_registries(capsys):
    assert main(["warmup", "--all", "--list"]) == 0
    labels = capsys.readouterr().out.splitlines()
    expected = [Variant("v-cavity", d, f, v).label for d, f, v in kernel_variants()]
    expected += [Variant("smith", d, f, v).label for d, f, v in kernel_variants()
                 if distributions.smith_walk_refusal(d) is None]
    # and the models of every estimator that has models (the registry's), for each walk it takes
    expected += ["exact estimator's models", "exact-f1 estimator's models", "exact-f1 estimator's models (smith walk)"]
    assert labels == expected
    assert len(set(labels)) == len(labels)  # every variant named apart


def test_one_axis_named_takes_every_value_of_the_others(capsys):
    assert main(["warmup", "--facet", "interfaced_lambertian", "--list"]) == 0
    labels = capsys.readouterr().out.splitlines()
    il = facets.get("interfaced_lambertian").VARIANTS
    assert len(labels) == len(distributions.NAMES) * len(il)
    assert all(" x interfaced_lambertian" in label and "walk" not in label for label in labels)


def test_models_alone_or_beside_variants(capsys):
    assert main(["warmup", "--models", "--list"]) == 0
    assert capsys.readouterr().out.splitlines() == [code.label for code in MODELS]
    assert main(["warmup", "--models", "--facet", "mirror", "--distribution", "ggx", "--list"]) == 0
    assert capsys.readouterr().out.splitlines() == ["ggx x mirror"] + [code.label for code in MODELS]
    estimators = {code.estimator for code in MODELS}
    assert estimators == {"exact", "exact-f1"}  # the estimators whose runs compile models


def test_repeated_values_and_flags_are_merged(capsys):
    """A flag given twice adds its values (argparse alone keeps the last one: ``--distribution
    ggx --distribution beckmann`` silently dropped ggx); a value named twice counts once."""
    argv = ["warmup", "--distribution", "ggx", "ggx", "--distribution", "beckmann", "ggx", "--facet", "mirror",
            "--facet", "conductor", "mirror", "--microsurface", "v-cavity", "--microsurface", "v-cavity", "--list"]
    assert main(argv) == 0
    assert capsys.readouterr().out.splitlines() == ["ggx x mirror", "ggx x conductor", "beckmann x mirror",
                                                    "beckmann x conductor"]


def _warmup_with(env_changes, *argv):
    env = {**os.environ, **env_changes}
    for name in [k for k, v in env.items() if v is None]:
        del env[name]
    return subprocess.run([sys.executable, "-m", "vcavity", "warmup", "-q", *argv], env=env, text=True,
                          capture_output=True, timeout=600)


def test_an_unusable_named_cache_is_one_line_naming_it(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    done = _warmup_with({"NUMBA_CACHE_DIR": str(blocker / "cache")}, "--distribution", "ggx", "--facet", "mirror")
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert done.stderr.splitlines() == [
        f"vcavity: error: NUMBA_CACHE_DIR = '{blocker / 'cache'}': cannot hold files (Not a directory); warmup fills "
        "the cache that runs with this NUMBA_CACHE_DIR read: name a writable folder, or unset it for the per-user "
        "cache"]


def test_no_writable_cache_at_all_is_one_line_naming_the_folders_tried(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    done = _warmup_with({"NUMBA_CACHE_DIR": None, "HOME": str(blocker), "XDG_CACHE_HOME": None,
                         "TMPDIR": str(blocker)}, "--models")
    assert done.returncode == 2 and done.stdout == "", done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("vcavity: error: no writable Numba cache folder: tried "), lines
    for folder in (blocker / ".cache" / "vcavity", blocker / f"vcavity-numba-cache-{uid}"):
        assert f"'{folder}" in lines[0], lines[0]
    assert lines[0].endswith("; set NUMBA_CACHE_DIR to a writable folder")


def test_with_the_jit_disabled_nothing_can_be_cached(tmp_path):
    done = _warmup_with({"NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_DISABLE_JIT": "1"}, "--models")
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert done.stderr.splitlines() == ["vcavity: error: NUMBA_DISABLE_JIT = '1': nothing is compiled, so nothing "
                                        "can be cached; unset it to fill the cache"]
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").rglob("*.nbi"))


#: distributions the Smith walk refuses (from the registry: the list changes as samplers arrive)
_NOT_WALKED = [name for name in distributions.NAMES if distributions.smith_walk_refusal(name) is not None]


@pytest.mark.parametrize("argv, expected", [
    ([], "name what to compile"),
    (["--distribution", "beckman"], "--distribution = 'beckman': must be one of beckmann, ggx"),
    (["--facet", "gold"], "--facet = 'gold': must be one of interfaced_lambertian"),
    pytest.param(["--microsurface", "smith", "--distribution", *_NOT_WALKED], "the Smith walk takes none of them",
                 marks=pytest.mark.skipif(not _NOT_WALKED, reason="the Smith walk takes every distribution")),
    (["--all", "--facet", "mirror"], "--all = every variant: it takes no --facet"),
])
def test_bad_selection_is_one_line_and_compiles_nothing(capsys, monkeypatch, argv, expected):
    import vcavity.simulate.warmup as warmup

    monkeypatch.setattr(warmup, "compile_variant", lambda variant: pytest.fail("compiled"))
    assert main(["warmup", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.splitlines()) == 1 and expected in captured.err, captured.err


class _Stream(io.StringIO):
    def __init__(self, tty):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


def _compiling(seconds):
    """What Numba does around a real compile (a cache miss): a ``numba:compile`` event."""
    with event.trigger_event("numba:compile", data={"dispatcher": None, "args": (), "return_type": None}):
        time.sleep(seconds)


@pytest.mark.parametrize("tty", [False, True])
def test_notice_appears_only_for_a_slow_compile_and_ends_its_line(tty):
    fast, slow, load = _Stream(tty), _Stream(tty), _Stream(tty)
    with CompileNotice("beckmann x mirror", stream=fast, delay=0.5):
        _compiling(0.0)
    with CompileNotice("beckmann x mirror", stream=load, delay=0.05):
        time.sleep(0.5)  # a slow cache load: no compile event
    with CompileNotice("beckmann x mirror", stream=slow, delay=0.05):
        _compiling(1.3)
    text = "vcavity: compiling the kernel for beckmann x mirror (first use; cached afterwards) ..."
    assert fast.getvalue() == "" and load.getvalue() == ""
    out = slow.getvalue()
    assert out.endswith(" 1 s\n") and out.count("\n") == 1 and out.split("\r")[-1].startswith(text), repr(out)
    assert ("\r" in out) == tty  # a terminal's line counts the seconds; a log gets one line


def test_the_notice_promises_a_cache_only_where_there_is_one():
    for cached, words in ((True, "(first use; cached afterwards)"), (False, "(not cached: compiled in every process)")):
        stream = _Stream(False)
        with CompileNotice("ggx x conductor", stream=stream, delay=0.01, code="every-order model", cached=cached):
            _compiling(0.3)
        assert stream.getvalue().startswith(f"vcavity: compiling the every-order model for ggx x conductor {words}")


def test_an_interrupted_compile_ends_the_notice_line_before_the_interrupt():
    stream = _Stream(False)
    with pytest.raises(KeyboardInterrupt):
        with CompileNotice("ggx x conductor", stream=stream, delay=0.01):
            with event.trigger_event("numba:compile", data={"dispatcher": None, "args": (), "return_type": None}):
                time.sleep(0.2)
                raise KeyboardInterrupt
    assert stream.getvalue().endswith("... stopped\n")


def test_the_default_runs_variant_is_named_as_a_run_would():
    from vcavity.config import default_config

    material = default_config().material
    variant = Variant.of_material(material)
    assert variant.label == f"{material.distribution} x {material.facet}"
    assert variant in variants(None, [material.distribution], [material.facet])


def test_a_variant_compiled_in_this_process_is_not_compiled_again():
    variant = Variant("v-cavity", "beckmann", "interfaced_lambertian", "interfaced lambertian")
    compile_variant(variant)  # compiled or loaded: whatever the cache holds
    assert compile_variant(variant)[1] is True


def _warmup(cache, *argv):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.Popen([sys.executable, "-m", "vcavity", "warmup", "-q", *argv], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


@pytest.mark.slow
def test_two_warmups_at_once_leave_a_working_cache(tmp_path):
    """Slow: two cold compiles of one variant at once (~1 min of CPU; minutes of wall on a busy machine)."""
    cache = tmp_path / "cache"
    selection = ["--distribution", "beckmann", "--facet", "mirror"]
    first, second = _warmup(cache, *selection), _warmup(cache, *selection)
    for proc in (first, second):
        out, err = proc.communicate(timeout=1200)
        assert proc.returncode == 0, err
        assert "1 variant(s) ready" in err and f"in {cache}" in err, err
    third = _warmup(cache, *selection)
    _, err = third.communicate(timeout=600)
    assert third.returncode == 0 and "(0 compiled, 1 loaded from the cache)" in err, err
    (tmp_path / "m.toml").write_text('[material]\ndistribution = "beckmann"\nalpha = 0.4\nfacet = "mirror"\n'
                                     "[incidence]\ntheta_i_deg = [30]\npaths = 5000\n"
                                     "[simulation]\nsensor_resolution = 9\n")
    run = subprocess.run([sys.executable, "-m", "vcavity", "run", "m.toml", "-q"], cwd=tmp_path, text=True,
                         capture_output=True, timeout=600, env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
    assert run.returncode == 0 and "kernel ready" in run.stderr, run.stderr
    assert "compiling the kernel" not in run.stderr, run.stderr  # loaded: no notice


@pytest.mark.slow
def test_warmup_models_fills_a_cold_cache_that_exact_runs_then_load(tmp_path):
    """Slow: the models' cold compile (a minute or more). Afterwards neither an exact nor an
    exact-f1 run compiles its models (no notice) and both say their code was loaded."""
    cache = tmp_path / "cache"
    proc = _warmup(cache, "--models")
    _, err = proc.communicate(timeout=1800)
    assert proc.returncode == 0 and "3 model code(s) ready in" in err and f"in {cache}" in err, err
    for estimator, extra in (("exact", ""), ("exact-f1", "paths = 20000\n")):
        (tmp_path / "m.toml").write_text('[material]\ndistribution = "ggx"\nalpha = 0.3\nfacet = "conductor"\n'
                                         f"[incidence]\ntheta_i_deg = [30]\n{extra}"
                                         f'[simulation]\nsensor_resolution = 9\nestimator = "{estimator}"\n')
        run = subprocess.run([sys.executable, "-m", "vcavity", "run", "m.toml", "-q", "-o", f"{estimator}.h5"],
                             cwd=tmp_path, text=True, capture_output=True, timeout=900,
                             env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
        assert run.returncode == 0 and "model code ready" in run.stderr, run.stderr
        assert "compiling the" not in run.stderr.replace("compiling the kernel", ""), run.stderr
