"""Where V-cavity and Smith differ: the tables quoted in docs/microsurfaces.md.

Reads a sweep file with a ``microsurface`` axis (v-cavity and smith) and a roughness axis
``alpha`` (runs/sweep_smith_vs_vcavity.toml) and prints

1. per theta_i and alpha, the albedo of f1, f2 and f_inf on both microsurfaces and the
   difference Smith - V-cavity with 2 sigma (sigma = quadrature sum of the two binomial
   standard errors, :mod:`vcavity.sweep.albedo`);
2. per theta_i at a few alphas, the in-plane cell (phi_o = phi_i: theta_o < 0; phi_i +
   180: theta_o > 0) where f2 and f_inf differ most, in units of sigma and in 1/sr, with
   the two values there: the numbers ``vcavity plot SWEEP --kind versus --point alpha=A``
   draws (:func:`vcavity.plots.versus.versus_data`).

Usage::

    python scripts/microsurface_table.py runs/sweep_smith_vs_vcavity.h5 [--alpha 0.3 0.6 1.0]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from vcavity.io.sweep_table import open_sweep
from vcavity.plots.sides import sweep_sides
from vcavity.plots.versus import versus_data
from vcavity.sweep.albedo import albedo, albedo_stderr

ORDERS = (1, 2, 0)
NAMES = {1: "f1", 2: "f2", 0: "f_inf"}


def _axis(sweep, name):
    return next(a for a in sweep.axes if a.name == name)


def albedo_rows(sweep):
    """Rows (theta_i, alpha, {order: (v-cavity, smith, difference, 2 sigma)}) of table 1."""
    names = [a.name for a in sweep.axes]
    surface, alpha, theta = (_axis(sweep, n) for n in ("microsurface", "alpha", "theta_i_deg"))
    where = {m: surface.values.index(m) for m in ("v-cavity", "smith")}
    values = {k: (albedo(sweep, k), albedo_stderr(sweep, k)) for k in ORDERS}
    rows = []
    for t, theta_value in enumerate(theta.values):
        for r, alpha_value in enumerate(alpha.values):
            cells = {}
            for k, (value, error) in values.items():
                at = {m: tuple({"microsurface": j, "alpha": r, "theta_i_deg": t}[n] for n in names)
                      for m, j in where.items()}
                v, s = value[at["v-cavity"]], value[at["smith"]]
                two_sigma = 2.0 * float(np.hypot(error[at["v-cavity"]], error[at["smith"]]))
                cells[k] = (v, s, s - v, two_sigma)
            rows.append((theta_value, alpha_value, cells))
    return rows


def print_albedo_table(sweep, out=sys.stdout):
    print("Albedo per order, V-cavity (V) and Smith (S); difference S - V +- 2 sigma", file=out)
    header = "theta_i alpha" + "".join(f" | {NAMES[k]:>6} V  {NAMES[k]:>6} S  {'S - V':>8} {'2 sigma':>7}"
                                       for k in ORDERS)
    print(header, file=out)
    for theta, alpha, cells in albedo_rows(sweep):
        line = f"{theta:7g} {alpha:5g}"
        for k in ORDERS:
            v, s, d, e = cells[k]
            line += f" | {v:8.4f} {s:8.4f} {d:+8.4f} {e:7.4f}"
        print(line, file=out)


def print_slice_table(sweep, alphas, out=sys.stdout):
    print("\nIn-plane cells where Smith - V-cavity is largest in sigma (theta_o < 0: toward the light)",
          file=out)
    print("alpha theta_i order  theta_o   V (1/sr)   S (1/sr)   S - V   2 sigma   (S - V)/sigma", file=out)
    for alpha in alphas:
        a, b = sweep_sides(sweep, [f"alpha={alpha:g}"], "microsurface=v-cavity,smith")
        pairs = [(j, j) for j in range(len(a.theta_i_deg))]
        data = versus_data(a, b, pairs, (2, 0))
        for (first, second), diff, error in zip(data.slices, data.difference, data.difference_stderr):
            for k in (2, 0):
                with np.errstate(divide="ignore", invalid="ignore"):
                    z = np.where(error[k] > 0, diff[k] / error[k], 0.0)
                i = int(np.argmax(np.abs(z)))
                print(f"{alpha:5g} {first.theta_i_deg:7g} {NAMES[k]:>5} {first.centers[i]:+8.1f} "
                      f"{first.brdf[k][i]:10.4f} {second.brdf[k][i]:10.4f} {diff[k][i]:+7.4f} "
                      f"{2 * error[k][i]:9.4f} {z[i]:+10.1f}", file=out)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", help="sweep file with microsurface and alpha axes")
    parser.add_argument("--alpha", nargs="+", type=float, default=[0.3, 0.6, 1.0],
                        help="roughnesses of the in-plane table (default 0.3 0.6 1.0)")
    args = parser.parse_args(argv)
    sweep = open_sweep(args.sweep)
    print_albedo_table(sweep)
    print_slice_table(sweep, args.alpha)
    return 0


if __name__ == "__main__":
    sys.exit(main())
