"""Plots of a deterministic table (``estimator = "exact"``) call its errors what they are,
the model's own error estimate, not "std. errors" (issue 38 item 2); an analog table's
plots still say std. errors. The albedo plot of an exact table draws the model's error of
the albedo (its cells' estimates summed over projected solid angle), not the binomial
rule with 0 paths (0/0: NaN bars and a RuntimeWarning).

Tables: a Beckmann mirror, exact and analog (the variants test_exact.py compiles), 9 x 9
cells. Text is read from the matplotlib figures; nothing here is statistical.
"""

import warnings

import numpy as np
import pytest
from matplotlib.text import Text

from vcavity import open_table
from vcavity.cli import main
from vcavity.plots import sides
from vcavity.plots.data import albedo_data, slice_data
from vcavity.plots.figures import albedo_figure, slice_figure
from vcavity.plots.versus import versus_data
from vcavity.plots.versus_figure import versus_figure

MIRROR = """[material]
distribution = "beckmann"
alpha = 0.5
facet = "mirror"
[incidence]
theta_i_deg = [10, 65]
paths = 20000
[simulation]
seed = 5
max_order = 3
sensor_resolution = 9
estimator = "{estimator}"
"""
ORDERS = (0, 1, 2)


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("model-error")
    made = {}
    for estimator in ("exact", "analog"):
        config = folder / f"{estimator}.toml"
        config.write_text(MIRROR.format(estimator=estimator))
        assert main(["run", str(config), "-o", str(folder / f"{estimator}.h5"), "-q"]) == 0
        made[estimator] = open_table(folder / f"{estimator}.h5")
    return made


def _text(fig) -> str:
    return " | ".join(t.get_text() for t in fig.findobj(Text) if t.get_text())


def _slice_text(table):
    return _text(slice_figure(table, [slice_data(table, j, ORDERS) for j in range(len(table.theta_i_deg))]))


def test_an_exact_tables_slices_and_albedo_say_model_error(tables):
    exact = tables["exact"]
    text = _slice_text(exact)
    assert "model error" in text and "std. error" not in text and "s.e." not in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the binomial rule at 0 paths divided by zero
        data = albedo_data(exact, ORDERS)
    text = _text(albedo_figure(exact, data, ORDERS))
    assert "model error" in text and "std. error" not in text
    area = np.asarray(exact.cell_projected_solid_angle)
    for k in ORDERS:
        expected = np.sum(np.asarray(exact.brdf_stderr)[:, exact.order_index(k), :] * area, axis=1)
        np.testing.assert_allclose(data.stderr[k], expected, rtol=1e-12)
        assert np.all(np.isfinite(data.stderr[k]))
    assert data.share_stderr is None  # no binomial error of the share either


def test_an_analog_tables_plots_still_say_std_errors(tables):
    analog = tables["analog"]
    assert "std. error" in _slice_text(analog) and "model error" not in _slice_text(analog)
    text = _text(albedo_figure(analog, albedo_data(analog, ORDERS), ORDERS))
    assert "std. error" in text and "model error" not in text


def test_versus_names_the_exact_sides_errors(tables):
    a, b = sides.table_side(tables["analog"]), sides.table_side(tables["exact"])
    pairs = [(j, j) for j in range(len(a.theta_i_deg))]
    text = _text(versus_figure(a, b, versus_data(a, b, pairs, ORDERS)))
    assert "B: the exact model's own error estimate" in text
    both_analog = _text(versus_figure(a, a, versus_data(a, a, pairs, ORDERS)))
    assert "model's own error" not in both_analog and "std. errors" in both_analog
