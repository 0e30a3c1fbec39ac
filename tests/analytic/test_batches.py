"""The analytic models' long loops in short compiled calls (vcavity/analytic/batches.py):
every item computed once, in order, whatever the batch sizes; the stop request polled
between calls; and the models' results bit-identical however their loops are cut
(tables must not change: the reference is the same model computed in one call per loop,
as before the loops were cut)."""

import math

import numpy as np
import pytest

from vcavity.analytic import batches
from vcavity.analytic.batches import ModelInterrupted, in_batches
from vcavity.config import validate
from vcavity.sensor.directions import incident_vector
from vcavity.sensor.grid import EqualAreaSensor


class _Clock:
    """A stand-in for the ``time`` module: each call of the batch takes ``steps`` seconds in turn."""

    def __init__(self, *steps):
        self.now, self.steps, self.calls = 0.0, list(steps), 0

    def perf_counter(self):
        self.calls += 1
        if self.calls % 2 == 0:  # the end of a call
            self.now += self.steps[min(self.calls // 2 - 1, len(self.steps) - 1)]
        return self.now


def test_every_item_once_in_order_with_sizes_within_bounds(monkeypatch):
    monkeypatch.setattr(batches, "time", _Clock(0.5))  # every call "takes" 0.5 s
    calls = []
    in_batches(1000, 7, lambda a, b: calls.append((a, b)), seconds=2.0, minimum=3, maximum=50)
    assert calls[0] == (0, 7)
    assert [a for a, _ in calls[1:]] == [b for _, b in calls[:-1]] and calls[-1][1] == 1000
    sizes = [b - a for a, b in calls[:-1]]
    # 0.5 s per call for an aim of 2 s: each size grows by MAX_GROWTH until the maximum
    assert sizes[:3] == [7, 28, 50] and max(sizes) == 50 and min(sizes) >= 3


def test_a_slow_call_shrinks_the_next_batch(monkeypatch):
    monkeypatch.setattr(batches, "time", _Clock(10.0, 0.25))
    calls = []
    in_batches(20, 8, lambda a, b: calls.append((a, b)), seconds=0.25)
    # 8 items took 10 s: the next call gets the 0.2 items that fit 0.25 s, at least one
    assert calls[:2] == [(0, 8), (8, 9)]


def test_the_stop_request_is_polled_before_every_call():
    calls, polls = [], []

    def should_stop():
        polls.append(len(calls))
        return len(calls) == 3

    with pytest.raises(ModelInterrupted):
        in_batches(100, 1, lambda a, b: calls.append((a, b)), should_stop, seconds=1e-9)
    assert polls == [0, 1, 2, 3] and len(calls) == 3
    assert issubclass(ModelInterrupted, KeyboardInterrupt)  # Ctrl-C handlers take it


def _one_call(monkeypatch, module):
    """The loops of ``module`` as before they were cut: one call over every item."""
    monkeypatch.setattr(module, "in_batches", lambda total, first, run, should_stop=None, **_: total and run(0, total))


def _tiny_batches(monkeypatch, module):
    """The loops of ``module`` cut as finely as the bounds allow (each batch aims at 0 s)."""
    real = batches.in_batches
    monkeypatch.setattr(module, "in_batches", lambda total, first, run, should_stop=None, **kw:
                        real(total, 1, run, should_stop, **dict(kw, seconds=0.0)))


def _material(**material):
    return validate({"material": material, "incidence": {"theta_i_deg": [30.0]}}).material


def test_every_order_model_is_the_same_in_one_call_and_in_tiny_batches(monkeypatch):
    """The mesh's vertices and quads in batches of one row / one chunk (the smallest) give
    the bits of one call per mesh, on a lossy conductor with a bounce cap that truncates."""
    from vcavity.analytic import specular_orders as so

    material = _material(distribution="ggx", alpha_x=0.3, alpha_y=0.7, facet="conductor")
    sensor = EqualAreaSensor(7)
    args = (material, incident_vector(math.radians(50.0), math.radians(20.0)), sensor, 2, 6)
    results = []
    for cut in (_one_call, _tiny_batches):
        with monkeypatch.context() as patch:
            cut(patch, so)
            results.append(so.specular_orders(*args, tolerance=math.inf, start_quads=16))
    whole, tiny = results
    assert whole.truncated > 0.0 and whole.integrals[1].sum() > 0.0  # the cases are exercised
    assert np.array_equal(whole.integrals, tiny.integrals) and np.array_equal(whole.error, tiny.error)
    assert whole.truncated == tiny.truncated and whole.truncated_error == tiny.truncated_error


def test_exact_f1_model_is_the_same_in_one_call_and_in_tiny_batches(monkeypatch):
    """Body, specular sub-cell rule and peak rays (a lobe narrow enough for peak cells),
    each loop cut into single cells or rays, give the bits of one call per loop."""
    from vcavity.analytic import cells, peak_rays
    from vcavity.analytic.exact_f1 import CellModel

    material = _material(distribution="beckmann", alpha=0.02, facet="interfaced_lambertian", kd=0.6, eta=1.5)
    sensor = EqualAreaSensor(5)
    incident = incident_vector(math.radians(35.0), 0.3)
    results = []
    for cut in (_one_call, _tiny_batches):
        with monkeypatch.context() as patch:
            cut(patch, cells)
            cut(patch, peak_rays)
            model = CellModel(material, incident, sensor, 1e-6, n_nodes=8)
            results.append((model.values, model.error, model.parts[0].peak))
    (values, error, peak), (tiny_values, tiny_error, _) = results
    assert peak.size > 0  # the peak rays are part of it
    assert np.array_equal(values, tiny_values) and np.array_equal(error, tiny_error)


@pytest.mark.parametrize("model", ["exact", "exact-f1"])
def test_a_model_stops_between_its_calls_when_asked(model):
    """The stop request is polled many times within one direction's model (not only
    between directions), and the model stops at the first True."""
    from vcavity.analytic.exact_f1 import CellModel
    from vcavity.analytic.specular_orders import specular_orders

    sensor = EqualAreaSensor(9)
    incident = incident_vector(math.radians(40.0), 0.0)
    if model == "exact":
        material = _material(distribution="beckmann", alpha=0.5, facet="mirror")
        compute = lambda stop: specular_orders(material, incident, sensor, 3, 100, tolerance=1e-9,  # noqa: E731
                                               max_quads=256, should_stop=stop)
    else:
        material = _material(distribution="ggx", alpha=0.5, facet="interfaced_lambertian", kd=0.8, eta=1.5)
        compute = lambda stop: CellModel(material, incident, sensor, 1e-6, should_stop=stop)  # noqa: E731
    polls = []
    compute(lambda: polls.append(1) and False)
    assert len(polls) >= 10, len(polls)
    asked = []

    def stop_at_fifth():
        asked.append(1)
        return len(asked) == 5

    with pytest.raises(ModelInterrupted):
        compute(stop_at_fifth)
    assert len(asked) == 5
