#!/usr/bin/env python
"""Numerical stress test of the V-cavity walk: extreme roughness, grazing light, extreme
indices. Prints one row per case and exits 1 if any invariant breaks.

    python scripts/stress.py [--quick] [--threads T] [--scale S] [--only SUBSTRING] [--markdown]

The grid sweeps every axis of the issue against a base material (Beckmann alpha 0.5, IL
kd 0.5, eta 1.5, theta_i 45 deg) and adds the nasty combinations: tiny roughness at grazing
light for every distribution, huge GGX roughness, 1000:1 anisotropy at grazing light,
eta 1 + 1e-9 and 1000 with kd 1e-6 and 1, every distribution with every compiled variant of
every facet model (the model's first example of each variant, from the registries), conductors
with extreme indices.
Each case is simulated, written to a real HDF5 table in a temporary folder and read back.

Invariants (a violation makes the exit status 1):
  finite     brdf, brdf_stderr and albedo finite; brdf >= 0
  books      exits + absorbed + truncated + degenerate == paths exactly, and the stored
             fractions sum to 1 within 1e-12; sum_c brdf * proj. solid angle == albedo
  cap        max_bounces_seen <= cap, and == cap when anything was truncated
  energy     mirror facets or kd == 1: nothing absorbed (physics.md sec. 4, 8)
  degenerate no path the walk could not trace
  f1         |z| <= 5 between the simulated f1 albedo and the exact V-groove single-bounce
             albedo (specular + body, sensor-independent; physics.md sec. 7: with G2_V the
             model IS the expectation of f1), z with the Monte-Carlo and quadrature errors
  spec       |z| <= 5 for the f1 share in the cell of the mirror direction (facets
             without a body, lobes narrow enough that this cell holds >= half of f1),
             the same reference restricted to that cell
Each z-test has a 5.7e-7 false-alarm probability (normal tails beyond 5 sigma).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numba
import numpy as np

from vcavity.sensor.binning import direction_to_cell
from vcavity.config import validate
from vcavity.facet import registry as facets
from vcavity.io.table import open_table, write_table
from vcavity.microfacet import registry as distributions
from vcavity.parameters import Roughness
from vcavity.rng import BLOCK_SIZE
from vcavity.simulate.pipeline import Simulation, incident_vector

sys.path.insert(0, str(Path(__file__).resolve().parent))  # also when imported by the tests
from stress_f1 import body_escape, clipped_cos_average, f1_reference, reemission_probability  # noqa: E402

__all__ = ["Case", "Row", "build_cases", "run_case", "main", "f1_reference", "body_escape", "clipped_cos_average",
           "reemission_probability", "roughness_of_width"]

Z_MAX = 5.0
CAP = 10_000
BASE = {"distribution": "beckmann", "alpha": 0.5, "facet": "interfaced_lambertian", "kd": 0.5, "eta": 1.5}


@dataclass(frozen=True)
class Case:
    """One stress case: a material (config [material] table) and one incident direction."""

    name: str
    material: dict
    theta_deg: float
    phi_deg: float = 0.0
    paths: int = 4_000_000


def _mat(**changes):
    """BASE with changes. A parameter of BASE's distribution or facet is dropped when the
    new one does not take it or the changes set the same parameter: facet='mirror' drops
    kd/eta, alpha_x/y or another law's parameter drops alpha (registries' declarations)."""
    m = dict(BASE)
    for component, registry in (("distribution", distributions), ("facet", facets)):
        new_keys = registry.config_keys(changes.get(component, m[component]))
        for spec in registry.get(m[component]).PARAMETERS:
            replaced = bool(set(spec.keys) & set(changes))
            for key in spec.keys:
                if key in m and key not in changes and (replaced or key not in new_keys):
                    del m[key]
    m.update(changes)
    return m


def roughness_of_width(dist: str, width: float) -> dict:
    """Config parameters of ``dist`` whose lobe width (the registry's ``lobe_width``, radians
    of theta_m) is ``width``: the roughness spec's first key, solved by bisection in log
    scale between its bounds; other required parameters get their documented example,
    optional ones keep their defaults."""
    specs = distributions.get(dist).PARAMETERS
    rough = next(spec for spec in specs if isinstance(spec, Roughness) or spec.default is None)
    raw = {spec.keys[0]: spec.example for spec in specs if spec is not rough and spec.default is None}

    def width_of(x):
        return distributions.lobe_width(dist, distributions.parse(dist, {**raw, rough.keys[0]: x}))

    if isinstance(rough, Roughness):
        lo, hi = 1e-300, 1e300
    else:
        lo = max(rough.lo if rough.lo is not None else -1e300, 1e-300)
        hi = rough.hi if rough.hi is not None else 1e300
        lo = lo if not rough.lo_open or lo != rough.lo else math.nextafter(lo, math.inf)
        hi = hi if not rough.hi_open or hi != rough.hi else math.nextafter(hi, -math.inf)
    increasing = width_of(hi) > width_of(lo)
    for _ in range(200):
        mid = math.sqrt(lo) * math.sqrt(hi)
        if (width_of(mid) < width) == increasing:
            lo = mid
        else:
            hi = mid
    return {**raw, rough.keys[0]: float(f"{math.sqrt(lo) * math.sqrt(hi):.6g}")}


# Roughness in each law's own parameter, for the distributions the grid was designed with;
# any other registered distribution gets the parameter of the same lobe width.
TINY = {"beckmann": {"alpha": 1e-4}, "ggx": {"alpha": 1e-4}, "phong": {"exponent": 2e8}, "gaussian": {"sigma": 1e-4}}
MODERATE = {"beckmann": {"alpha": 0.5}, "ggx": {"alpha": 0.5}, "phong": {"exponent": 6.0}, "gaussian": {"sigma": 0.35}}


def _tiny(dist):
    """Roughness ~1e-4 rad in each law's own parameter (phong: 2/alpha^2 - 2)."""
    return TINY[dist] if dist in TINY else roughness_of_width(dist, 1e-4)


def _moderate(dist):
    """Roughness comparable to BASE's alpha 0.5 in each law's parameter."""
    return MODERATE[dist] if dist in MODERATE else roughness_of_width(dist, 0.5)


DISTS = distributions.NAMES  # every registered distribution (build_cases reads the registry itself)


def build_cases(quick: bool = False) -> list[Case]:
    """The covering grid (quick: 12 of its nastiest cases with 40x fewer paths)."""
    c = []
    # 1. each axis against the base case
    for a in (1e-4, 1e-3, 0.01, 0.1, 1.0, 3.0, 10.0):
        for d in ("beckmann", "ggx"):
            c.append(Case(f"alpha={a:g} {d}", _mat(distribution=d, alpha=a), 45.0,
                          paths=1_000_000 if a >= 3 else 4_000_000))
    for t in (0.0, 45.0, 80.0, 89.0, 89.9, 89.99):
        c.append(Case(f"theta={t:g}", _mat(), t))
    for e in (1.0, 1 + 1e-9, 1.0001, 1.5, 3.0, 10.0, 1000.0):
        c.append(Case(f"eta={e:.10g}", _mat(eta=e), 45.0))
    for k in (0.0, 1e-6, 0.5, 1.0):
        c.append(Case(f"kd={k:g}", _mat(kd=k), 45.0))
    for r in (10, 100, 1000):
        for p in (0.0, 90.0):
            c.append(Case(f"aniso {r}:1 phi={p:g}", _mat(alpha_x=0.5, alpha_y=0.5 / r), 45.0, p))
    for d in distributions.NAMES:
        for f, label, example in facets.variant_examples():
            c.append(Case(f"dist {d} {_SHORT.get(f, f)} {label}", _mat(distribution=d, facet=f, **example,
                                                                       **_moderate(d)), 45.0))
    # 2. nasty combinations
    for d in distributions.NAMES:
        for t in (0.0, 89.99):
            c.append(Case(f"tiny {d} mirror", _mat(distribution=d, facet="mirror", **_tiny(d)), t))
            c.append(Case(f"tiny {d} IL kd=1", _mat(distribution=d, kd=1.0, **_tiny(d)), t))
        c.append(Case(f"tiny {d} lambert kd=1", _mat(distribution=d, kd=1.0, eta=1.0, **_tiny(d)), 89.99))
    for a in (3.0, 10.0):
        for t in (0.0, 89.99):
            c.append(Case(f"huge ggx a={a:g} mirror", _mat(distribution="ggx", alpha=a, facet="mirror"), t))
            c.append(Case(f"huge ggx a={a:g} IL kd=1", _mat(distribution="ggx", alpha=a, kd=1.0), t,
                          paths=200_000))
    c.append(Case("huge beckmann a=10 IL kd=1", _mat(alpha=10.0, kd=1.0), 0.0, paths=1_000_000))
    c.append(Case("phong exponent=0 IL kd=1", _mat(distribution="phong", exponent=0.0, kd=1.0), 0.0))
    for s in (2.0, 10.0):
        c.append(Case(f"gaussian sigma={s:g} mirror", _mat(distribution="gaussian", sigma=s, facet="mirror"), 0.0))
        c.append(Case(f"gaussian sigma={s:g} IL kd=1", _mat(distribution="gaussian", sigma=s, kd=1.0), 0.0,
                      paths=200_000))
    for d in ("beckmann", "ggx"):
        for p in (0.0, 45.0, 90.0):
            c.append(Case(f"aniso 1000:1 {d} mirror", _mat(distribution=d, alpha_x=1.0, alpha_y=1e-3,
                                                           facet="mirror"), 89.99, p))
        c.append(Case(f"aniso 1000:1 {d} IL kd=1", _mat(distribution=d, alpha_x=1.0, alpha_y=1e-3, kd=1.0),
                      89.99, 45.0))
    for e in (1 + 1e-9, 1000.0):
        for k in (1e-6, 1.0):
            for t in (0.0, 89.9):
                c.append(Case(f"eta={e:.10g} kd={k:g}", _mat(eta=e, kd=k), t))
        c.append(Case(f"eta={e:.10g} kd=0 grazing", _mat(eta=e, kd=0.0), 89.99))
    for eta, k in ((0.05, 20.0), (1e-3, 1e6), (0.7, 0.0), (1e6, 1e-3)):  # metals far out; eta < 1, k = 0: TIR
        for t in (0.0, 89.9):
            c.append(Case(f"conductor eta={eta:g} k={k:g}", _mat(facet="conductor", eta=eta, k=k), t))
    c.append(Case("eta=1e4 kd=1 (rejection)", _mat(eta=1e4, kd=1.0), 0.0))
    c.append(Case("eta=1e300 kd=1", _mat(eta=1e300, kd=1.0), 45.0))
    c.append(Case("lambert ggx a=3 kd=1", _mat(distribution="ggx", alpha=3.0, eta=1.0, kd=1.0), 60.0,
                  paths=400_000))
    if not quick:
        return c
    # three kernel variants only (beckmann IL, ggx IL, ggx mirror): each costs ~15 s to
    # compile when the Numba cache is cold
    keep = {("theta=89.99", 89.99, 0.0), ("alpha=0.001 beckmann", 45.0, 0.0), ("tiny ggx mirror", 89.99, 0.0),
            ("tiny ggx IL kd=1", 0.0, 0.0), ("huge ggx a=10 IL kd=1", 0.0, 0.0), ("huge ggx a=10 mirror", 89.99, 0.0),
            ("aniso 1000:1 ggx mirror", 89.99, 45.0), ("aniso 1000:1 ggx IL kd=1", 89.99, 45.0),
            ("eta=1.000000001 kd=1", 89.9, 0.0), ("eta=1000 kd=1e-06", 0.0, 0.0), ("eta=1e300 kd=1", 45.0, 0.0),
            ("kd=1e-06", 45.0, 0.0)}
    picked = [x for x in c if (x.name, x.theta_deg, x.phi_deg) in keep]
    return [replace(x, paths=max(20_000, x.paths // 40)) for x in picked]


# ------------------------------------------------------------------- one case


@dataclass
class Row:
    """Outcome of one case: measured ``values`` and the ``violations`` (messages)."""

    case: Case
    values: dict = field(default_factory=dict)
    violations: list = field(default_factory=list)


def case_seed(case: Case) -> int:
    """A seed of its own per case (cases sharing an incident direction would otherwise
    share their random streams, and so their Monte-Carlo errors)."""
    return zlib.crc32(f"{case.name}|{case.theta_deg}|{case.phi_deg}".encode())


def _z(sim, ref, ref_err, paths):
    var = max(ref * (1.0 - ref), 1.0 / paths) / paths + ref_err * ref_err
    return (sim - ref) / math.sqrt(var)


def _lossless(material) -> bool:
    """True when no facet event absorbs (physics.md sec. 4, 8): at every cosine the facet
    reflects with R and sends T into a body that re-emits a share a of it, and
    ``R + T a >= 1 - 1e-12`` (a mirror: R = 1; IL with kd = 1: R + T = 1 and a = 1)."""
    kind, _, data = facets.prepare(material.facet, material.facet_params)
    a = reemission_probability(material)
    return all(facets.reflectance(kind, c, data) + facets.transmittance(kind, c, data) * a >= 1.0 - 1e-12
               for c in np.linspace(0.0, 1.0, 65))


def run_case(case: Case, threads: int | None = None, scale: float = 1.0) -> Row:
    """Simulate one case, write and re-read its table, measure and check the invariants.

    Parameters
    ----------
    case : Case
    threads : int, optional
        Numba threads (default: all cores); does not change the result.
    scale : float, optional
        Multiplies the case's path budget (at least one RNG block is traced).

    Returns
    -------
    Row
        ``values`` (the printed measurements) and ``violations`` (one message per broken
        invariant; empty when the case passes).
    """
    paths = max(BLOCK_SIZE, int(case.paths * scale))
    cfg = validate({"material": case.material,
                    "incidence": {"theta_i_deg": [case.theta_deg], "phi_i_deg": case.phi_deg, "paths": paths},
                    "simulation": {"seed": case_seed(case), "max_order": 3, "max_bounces": CAP}})
    sim = Simulation(cfg, threads=threads)
    result = sim.run()
    books = dict(zip(sim.estimator.STATS, sim.last_state.stats[0]))  # the direction's integer path counts
    row = Row(case)
    v = row.values
    v.update(paths=paths, nonfinite=-1, book_err=math.nan, truncated=math.nan, degenerate=-1, max_bounces=-1,
             rate=math.nan, f1_sim=math.nan, f1_ref=math.nan, z_f1=math.nan, z_spec=math.nan)
    bad = row.violations.append
    exits = int(result["counts"][0, 0].sum())
    lost = int(books["absorbed"] + books["truncated"] + books["degenerate"])
    if exits + lost != paths:  # write_table would refuse the table
        bad(f"books: exits {exits} + lost {lost} != paths {paths}")
        return row
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "stress.h5"
        write_table(path, result)
        table = open_table(path)
    v["nonfinite"] = int(sum(np.count_nonzero(~np.isfinite(a)) for a in (table.brdf, table.brdf_stderr, table.albedo)))
    if v["nonfinite"] or np.any(table.brdf < 0.0):
        bad(f"finite: {v['nonfinite']} NaN/Inf, {np.count_nonzero(table.brdf < 0.0)} negative")
    k0, k1 = table.order_index(0), table.order_index(1)
    v["book_err"] = abs(table.albedo[0, k0] + table.absorbed[0] + table.truncated[0] + table.degenerate[0] - 1.0)
    proj_sum = np.abs((table.brdf[0] * table.cell_projected_solid_angle).sum(axis=1) - table.albedo[0]).max()
    if v["book_err"] > 1e-12 or proj_sum > 1e-12:
        bad(f"books: stored fractions sum to 1 + {v['book_err']:.1e}; sum brdf*proj - albedo {proj_sum:.1e}")
    v["truncated"] = float(table.truncated[0])
    v["degenerate"] = int(books["degenerate"])
    v["max_bounces"] = int(table.max_bounces_seen[0])
    if v["max_bounces"] > CAP or (books["truncated"] > 0 and v["max_bounces"] != CAP):
        bad(f"cap: max_bounces_seen {v['max_bounces']} with cap {CAP}")
    conserving = _lossless(cfg.material)
    if conserving and books["absorbed"] != 0:
        bad(f"energy: {books['absorbed']} paths absorbed with kd = 1 / mirror facets")
    if v["degenerate"]:
        bad(f"degenerate: {v['degenerate']} paths")
    seconds = result.attrs["compute_time_s"]
    v["rate"] = paths / seconds if seconds > 0 else math.inf
    f1_ref, f1_err, spec_ref, spec_err = f1_reference(case.material, case.theta_deg, case.phi_deg)
    v["f1_sim"] = float(table.counts[0, k1].sum()) / paths
    v["f1_ref"], v["f1_err"] = f1_ref, f1_err
    v["z_f1"] = _z(v["f1_sim"], f1_ref, f1_err, paths)
    if abs(v["z_f1"]) > Z_MAX:
        bad(f"f1: simulated {v['f1_sim']:.6f} vs exact {f1_ref:.6f} +- {f1_err:.1e} (z = {v['z_f1']:.1f})")
    v["z_spec"] = math.nan
    v["spec_ref"] = spec_ref
    # only for a lobe narrow enough that most of f1 lands in the mirror cell: for broad
    # lobes the indicator of one small cell is not resolved by the groove grid
    if reemission_probability(cfg.material) == 0.0 and spec_ref >= 0.5 * f1_ref:
        i = incident_vector(math.radians(case.theta_deg), math.radians(case.phi_deg))
        cell = int(direction_to_cell(-i[0], -i[1], i[2], table.sensor.resolution))
        v["spec_sim"] = float(table.counts[0, k1, cell]) / paths
        v["z_spec"] = _z(v["spec_sim"], spec_ref, spec_err, paths)
        if abs(v["z_spec"]) > Z_MAX:
            bad(f"spec: mirror-cell share {v['spec_sim']:.6f} vs exact {spec_ref:.6f} (z = {v['z_spec']:.1f})")
    return row


# ------------------------------------------------------------------- report


_SHORT = {"alpha": "a", "exponent": "e", "sigma": "s", "interfaced_lambertian": "IL"}


def describe(material: dict) -> str:
    """Short material label, e.g. ``ggx a=10 IL kd=1 eta=1.5``."""
    m = validate({"material": material}).material.to_dict() | material  # the facet's defaults too
    dist, facet = m["distribution"], m["facet"]

    def short(key):
        head, _, tail = key.partition("_")
        return _SHORT.get(head, head) + ("_" + tail if tail else "")

    rough = " ".join(f"{short(k)}={m[k]:g}" for k in distributions.config_keys(dist) if k in material)
    facet_values = " ".join(f"{k}={m[k]:.10g}" for k in facets.config_keys(facet))
    return " ".join(x for x in (dist, rough, _SHORT.get(facet, facet), facet_values) if x)


HEADER = ("case", "material", "theta_i", "phi_i", "paths", "NaN/Inf", "books err", "truncated",
          "degen", "max bnc", "Mpaths/s", "f1 sim", "f1 exact", "z f1", "z spec", "ok")


def format_row(row: Row) -> tuple:
    """The printed cells of one row, in the order of ``HEADER``."""
    v, c = row.values, row.case
    return (c.name, describe(c.material), f"{c.theta_deg:g}", f"{c.phi_deg:g}", f"{v['paths']:.0e}",
            str(v["nonfinite"]), f"{v['book_err']:.0e}", f"{v['truncated']:.1e}", str(v["degenerate"]),
            str(v["max_bounces"]), f"{v['rate'] / 1e6:.2f}", f"{v['f1_sim']:.6f}", f"{v['f1_ref']:.6f}",
            f"{v['z_f1']:+.1f}", "" if math.isnan(v["z_spec"]) else f"{v['z_spec']:+.1f}",
            "ok" if not row.violations else "FAIL")


def main(argv: list[str] | None = None) -> int:
    """Run the grid, print the table; return 0 if every invariant holds, else 1."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="12-case subset with 40x fewer paths")
    parser.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    parser.add_argument("--scale", type=float, default=1.0, help="multiply every path budget")
    parser.add_argument("--only", default=None, help="run the cases whose name contains this")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args(argv)
    cases = [c for c in build_cases(args.quick) if args.only is None or args.only in c.name]
    threads = args.threads or numba.config.NUMBA_NUM_THREADS
    print(f"# vcavity stress: {len(cases)} cases, {threads} threads, cap {CAP} bounces, "
          f"numba {numba.__version__}", flush=True)
    start = time.perf_counter()
    rows = []
    for case in cases:
        rows.append(run_case(case, threads=threads, scale=args.scale))
        cells = format_row(rows[-1])
        if args.markdown:
            if len(rows) == 1:
                print("| " + " | ".join(HEADER) + " |\n|" + "---|" * len(HEADER))
            print("| " + " | ".join(cells) + " |", flush=True)
        else:
            print("  ".join(f"{x:<26}" if j == 0 else f"{x:<34}" if j == 1 else f"{x:>{max(len(h), 6)}}"
                            for j, (x, h) in enumerate(zip(cells, HEADER))), flush=True)
    failures = [(r.case, msg) for r in rows for msg in r.violations]
    print(f"# {len(rows)} cases in {time.perf_counter() - start:.1f} s; {len(failures)} invariant violation(s)")
    for case, msg in failures:
        print(f"FAIL {case.name} theta_i={case.theta_deg:g} phi_i={case.phi_deg:g}: {msg}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
