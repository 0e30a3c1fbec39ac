"""The analytic models' compile is a step of its own (vcavity/estimators/models.py): made
before the models on a tiny input, announced like the kernel's, timed apart from the model
time (``model_compile_time_s``), and what ``vcavity warmup --models`` caches is what runs
of the exact and exact-f1 estimators use.

Whether a step compiled everything is read from the Numba dispatchers themselves: the
number of compiled signatures of every jitted function of vcavity, in a fresh process,
before and after (a cache load counts as well as a compile, so a warm cache cannot hide a
function the step forgot)."""

import json
import subprocess
import sys
import textwrap

import h5py
import pytest

from vcavity.cli import main

_PROBE = textwrap.dedent("""
    import json, sys
    from numba.core.registry import CPUDispatcher

    def signatures():
        return {f"{v.py_func.__module__}.{v.py_func.__qualname__}": len(v.overloads)
                for name, module in list(sys.modules.items()) if name.startswith("vcavity")
                for v in list(vars(module).values()) if isinstance(v, CPUDispatcher)}

    def grown(before, after):
        return sorted(k for k in after if after[k] > before.get(k, 0))

    from vcavity import config
    from vcavity.estimators import registry
    from vcavity.sensor.grid import EqualAreaSensor
    from vcavity.simulate.warmup import MODELS, compile_models

    step, runs = sys.argv[1], json.loads(sys.argv[2])
    models = []
    for estimator, material in runs:
        cfg = config.validate({"material": material, "simulation": {"estimator": estimator, "sensor_resolution": 9},
                               "incidence": {"theta_i_deg": [0, 40, 75], "phi_i_deg": 20, "paths": 10**6}})
        models.append(registry.get(estimator).models(cfg, EqualAreaSensor(cfg.sensor_resolution)))
    start = signatures()
    if step == "own":
        for m in models:
            m.compile()
    else:
        for code in MODELS:
            compile_models(code)
    compiled = signatures()
    for m in models:
        m.prepare()
    print(json.dumps({"step": grown(start, compiled), "models": grown(compiled, signatures())}))
""")


def _probe(step, runs):
    done = subprocess.run([sys.executable, "-c", _PROBE, step, json.dumps(runs)], capture_output=True, text=True,
                          timeout=1200)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


_EXACT = [
    {"distribution": "beckmann", "alpha": 0.5, "facet": "mirror"},
    {"distribution": "ggx", "alpha_x": 0.2, "alpha_y": 0.6, "facet": "interfaced_lambertian", "kd": 0.0, "eta": 1.5},
]
_EXACT_F1 = [
    # body, specular and the peak rays of a lobe narrower than a cell
    {"distribution": "beckmann", "alpha": 0.01, "facet": "interfaced_lambertian", "kd": 0.5, "eta": 1.5},
    # the Smith model of an anisotropic conductor (specular only)
    {"microsurface": "smith", "distribution": "ggx", "alpha_x": 0.2, "alpha_y": 0.5, "facet": "conductor"},
    {"distribution": "phong", "exponent": 30.0, "facet": "interfaced_lambertian", "kd": 0.7, "eta": 1.0},  # body only
]


@pytest.mark.parametrize("estimator, material", [("exact", m) for m in _EXACT] + [("exact-f1", m) for m in _EXACT_F1])
def test_after_its_compile_step_a_model_compiles_nothing(estimator, material):
    seen = _probe("own", [[estimator, material]])
    assert seen["step"], "the probe saw no compile at all"
    assert seen["models"] == [], f"compiled while computing the model: {seen['models']}"


def test_what_warmup_models_compiles_is_all_the_models_of_other_materials_need():
    seen = _probe("warmup", [["exact", m] for m in _EXACT] + [["exact-f1", m] for m in _EXACT_F1])
    assert seen["step"] and seen["models"] == [], seen["models"]


_CONDUCTOR = """[material]
distribution = "ggx"
alpha = 0.5
facet = "conductor"
[incidence]
theta_i_deg = [30]
{paths}[simulation]
max_order = 2
sensor_resolution = 9
estimator = "{estimator}"
"""


@pytest.mark.parametrize("estimator", ["exact", "exact-f1"])
def test_the_compile_is_timed_and_said_apart_from_the_model(tmp_path, capsys, monkeypatch, estimator):
    """A stand-in compile step of 2 s: its time is ``model_compile_time_s`` and the run's
    lines say it, and none of it is in ``model_time_s``."""
    import time

    from vcavity.estimators import exact, exact_f1

    module = exact if estimator == "exact" else exact_f1
    model_class = module.ExactModels if estimator == "exact" else module.F1Models
    real = model_class.compile_code
    monkeypatch.setattr(model_class, "compile_code", lambda self: (time.sleep(2.0), real(self)))
    config = tmp_path / "c.toml"
    config.write_text(_CONDUCTOR.format(estimator=estimator, paths="paths = 20000\n" if estimator != "exact" else ""))
    out = tmp_path / "c.h5"
    assert main(["run", str(config), "-o", str(out), "-q"]) == 0
    captured = capsys.readouterr()
    with h5py.File(out) as h5:
        compile_s, model_s = h5.attrs["model_compile_time_s"], h5.attrs["model_time_s"]
    assert compile_s >= 2.0 and model_s < 2.0, (compile_s, model_s)
    code = model_class.CODE
    assert f"vcavity: {code} code ready in {compile_s:.2f} s (compile or cache load, not counted as model time)" \
        in captured.err
    assert f"model compile/load {compile_s:.2f} s" in captured.out


def test_a_run_without_models_keeps_a_zero_model_compile_time(tmp_path, capsys):
    config = tmp_path / "a.toml"
    config.write_text(_CONDUCTOR.format(estimator="analog", paths="paths = 20000\n"))
    assert main(["run", str(config), "-o", str(tmp_path / "a.h5"), "-q"]) == 0
    assert "model compile/load" not in capsys.readouterr().out
    with h5py.File(tmp_path / "a.h5") as h5:
        assert h5.attrs["model_compile_time_s"] == 0.0


def test_an_interrupt_while_exact_f1_refines_stops_the_run_with_every_path_kept(monkeypatch):
    """The stop request comes once every path is traced, while the models are refined to
    the counts (made necessary here by a tolerance factor a thousand times tighter than
    the run's): the run stops at once with :class:`RunInterrupted` carrying the finished
    state (the service then saves it as the checkpoint), not after the refinement."""
    from vcavity import config as config_mod
    from vcavity.estimators import exact_f1
    from vcavity.simulate.pipeline import RunInterrupted, Simulation

    cfg = config_mod.validate({
        "material": {"distribution": "beckmann", "alpha": 0.6, "kd": 0.9, "eta": 1.5},
        "incidence": {"theta_i_deg": [30.0], "paths": 40_000},
        "simulation": {"estimator": "exact-f1", "sensor_resolution": 7}})
    simulation = Simulation(cfg, threads=1)
    simulation.prepare_models()
    monkeypatch.setattr(exact_f1, "MODEL_TOLERANCE_FACTOR", 1e-4)
    polled_while_refining = []

    def stop():
        refining = simulation.last_state is not None  # set once the last chunk is merged
        polled_while_refining.append(refining)
        return refining

    with pytest.raises(RunInterrupted) as stopped:
        simulation.run(should_stop=stop)
    state = stopped.value.state
    assert state.finished.all() and int(simulation.paths_done(state).sum()) == 40_000
    assert polled_while_refining.count(True) == 1  # stopped at the first poll of the refinement
