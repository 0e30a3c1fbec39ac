"""The every-order model of specular V-cavities against the walk, per order (physics.md
sec. 12-13): tables of 1e8 paths a direction, simulated by the analog kernel, tested with
``vcavity.compare.compare_order`` (Pearson chi-square over cells + albedo z-test of each
order: f1, f2, f3, f_inf) against the deterministic model, which shares no code with the
walk but the distribution's sampler and the facet's reflectance. Each configuration and
order is one test at family level 1e-3 (Sidak over its directions and two statistics);
with 31 such tests (8 configurations x 4 orders, one untestable) the file raises a
false alarm with probability about 3.1e-2 (fixed seeds: the outcome of a given tree is deterministic)."""

import pytest

from vcavity import config as config_mod
from vcavity.compare import compare_order, format_order_report
from vcavity.io.writer import write_table
from vcavity.io.table import open_table
from vcavity.simulate.pipeline import simulate

pytestmark = pytest.mark.slow

PATHS = 100_000_000
CONFIGS = {
    "beckmann-0.3-mirror": ({"distribution": "beckmann", "alpha": 0.3, "facet": "mirror"}, [0.0, 60.0, 85.0], 0.0),
    "ggx-aniso-mirror-phi45": ({"distribution": "ggx", "alpha_x": 0.6, "alpha_y": 0.2, "facet": "mirror"},
                               [40.0, 85.0], 45.0),
    "beckmann-aniso-mirror-phi0": ({"distribution": "beckmann", "alpha_x": 1.0, "alpha_y": 0.4, "facet": "mirror"},
                                   [60.0], 0.0),
    "beckmann-aniso-mirror-phi90": ({"distribution": "beckmann", "alpha_x": 1.0, "alpha_y": 0.4, "facet": "mirror"},
                                    [60.0], 90.0),
    "dielectric-1.5": ({"distribution": "beckmann", "alpha": 0.5, "facet": "interfaced_lambertian", "kd": 0.0,
                        "eta": 1.5}, [30.0, 80.0], 0.0),
    "dielectric-2.5": ({"distribution": "ggx", "alpha": 0.4, "facet": "interfaced_lambertian", "kd": 0.0,
                        "eta": 2.5}, [0.0, 70.0], 0.0),
    "ggx-1.0-mirror-deep": ({"distribution": "ggx", "alpha": 1.0, "facet": "mirror"}, [20.0, 75.0], 0.0),
    # gold at 450.9 nm (Johnson & Christy 1972), where F varies most with the angle
    "gold-conductor": ({"distribution": "ggx", "alpha": 0.5, "facet": "conductor", "eta": 1.38, "k": 1.914},
                       [20.0, 75.0], 0.0),
}


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    folder = tmp_path_factory.mktemp("specular-orders")
    made = {}

    def table(name):
        if name not in made:
            material, thetas, phi = CONFIGS[name]
            cfg = config_mod.validate({
                "material": material, "incidence": {"theta_i_deg": thetas, "phi_i_deg": phi, "paths": PATHS},
                "simulation": {"seed": 20261203, "max_order": 3, "sensor_resolution": 33}})
            path = folder / f"{name}.h5"
            write_table(path, simulate(cfg))
            made[name] = open_table(path)
        return made[name]

    return table


#: A smooth mirror has next to no third order (Beckmann 0.3: 0.4 of 1e8 paths expected):
#: its f3 is untestable there (a chi-square of one category), the other orders are tested.
UNTESTABLE = {("beckmann-0.3-mirror", 3)}
CASES = [pytest.param(name, order, id=f"{name}-{'f_inf' if order == 0 else f'f{order}'}")
         for name in CONFIGS for order in (1, 2, 3, 0) if (name, order) not in UNTESTABLE]


@pytest.mark.parametrize("name, order", CASES)
def test_every_order_of_the_walk_is_the_model(tables, name, order):
    report = compare_order(tables(name), order, significance=1e-3)
    assert report.passed, format_order_report(report)
