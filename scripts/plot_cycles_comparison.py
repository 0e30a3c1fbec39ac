"""Cycles' ``table_ggx_E`` against vcavity's, on the Smith and the V-cavity microsurface.

Reads two ``--layout cycles`` exports (``.npz``, with the tables ``E_f1`` and ``E``, i.e.
f1 and f_inf) of GGX with white mirror facets on Cycles' 32 x 32 nodes, the Smith one
(runs/sweep_cycles_ggx_E_smith.toml) and the V-cavity one (runs/sweep_albedo_lut_cycles.toml),
and Cycles' shipped table (tests/reference/data/cycles_ggx_E.tables, quoted from Blender's
``intern/cycles/scene/shader.tables``). Prints the figures quoted in docs/exports.md
(max and mean |difference| over the 1024 entries, E_avg per roughness) and draws
``-o PNG``: Cycles' E, Smith's E_f1 and their difference; the V-cavity's E_f1, its
difference to Smith's, and E_avg against r. ``--check K`` evaluates, at the K entries
where Smith's E_f1 and Cycles' differ most, an independent quadrature of the same
integral (tests/reference/smith_albedo.py, plain NumPy; about 4 s an entry): which side
the difference comes from.

Usage::

    python scripts/plot_cycles_comparison.py SMITH.npz VCAVITY.npz [-o docs/img/cycles_ggx_E.png] [--check 5]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # tests.reference: the quoted table and its parser
from tests.reference import cycles_tables, smith_albedo  # noqa: E402


def _load(path: str) -> dict:
    lut = np.load(path)
    missing = [k for k in ("E_f1", "E", "E_avg_f1", "E_avg", "r", "mu") if k not in lut.files]
    if missing or str(lut["layout"]).split(":")[0] != "Cycles":
        sys.exit(f"{path}: not a --layout cycles export with E_f1 and E (missing {missing}); "
                 "export with --format albedo-lut --layout cycles --orders 1 inf")
    return {k: lut[k] for k in lut.files}


def _stats(label: str, a: np.ndarray, b: np.ndarray) -> str:
    d = np.abs(a - b)
    y, x = np.unravel_index(np.argmax(d), d.shape)
    return (f"{label}: max |d| {d.max():.3g} at y = {y} (mu = {max(y / 31, 1e-4):.4g}), x = {x} "
            f"(r = {max(x / 31, 1e-4):.4g}); mean |d| {d.mean():.3g}; without the grazing row y = 0: "
            f"max {d[1:].max():.3g}, mean {d[1:].mean():.3g}")


def report(smith: dict, vcavity: dict, E: np.ndarray, E_avg: np.ndarray) -> list[str]:
    """The figures of docs/exports.md, one line each."""
    lines = [_stats("Smith E_f1 - Cycles E", smith["E_f1"], E),
             _stats("V-cavity E_f1 - Cycles E", vcavity["E_f1"], E),
             _stats("V-cavity E_f1 - Smith E_f1", vcavity["E_f1"], smith["E_f1"])]
    d = vcavity["E_f1"] - smith["E_f1"]
    lines.append(f"V-cavity E_f1 - Smith E_f1, signed: from {d.min():+.3g} to {d.max():+.3g}; the energy a "
                 f"compensation lobe adds, 1 - E_f1, mean {np.mean(1 - vcavity['E_f1']):.4f} (V-cavity) against "
                 f"{np.mean(1 - smith['E_f1']):.4f} (Smith); 1 - E_avg_f1 at r = 1: "
                 f"{1 - vcavity['E_avg_f1'][31]:.4f} against {1 - smith['E_avg_f1'][31]:.4f}")
    for name, lut in (("Smith", smith), ("V-cavity", vcavity)):
        d = np.abs(lut["E_avg_f1"] - E_avg)
        lines.append(f"{name} E_avg_f1 - Cycles E_avg: max |d| {d.max():.3g} (x = {np.argmax(d)}), mean {d.mean():.3g}")
        lines.append(f"{name} E (f_inf): max |E - 1| {np.max(np.abs(lut['E'] - 1)):.3g}, "
                     f"E_avg in [{lut['E_avg'].min():.6f}, {lut['E_avg'].max():.6f}]")
    lines.append("E_avg by r (x: Cycles, Smith, V-cavity E_avg_f1): " + "; ".join(
        f"{x}: {E_avg[x]:.6f} {smith['E_avg_f1'][x]:.6f} {vcavity['E_avg_f1'][x]:.6f}" for x in (*range(0, 32, 5), 31)))
    return lines


def check(smith: dict, E: np.ndarray, count: int) -> list[str]:
    """Independent quadrature at the ``count`` entries of largest |Smith E_f1 - Cycles E|."""
    d = np.abs(smith["E_f1"] - E)
    lines = []
    for flat in np.argsort(d, axis=None)[::-1][:count]:
        y, x = np.unravel_index(flat, d.shape)
        quad = smith_albedo.albedo(max(x / 31, 1e-4), max(y / 31, 1e-4))
        lines.append(f"y = {y}, x = {x}: quadrature {quad:.7f}; Smith - quadrature {smith['E_f1'][y, x] - quad:+.2e}, "
                     f"Cycles - quadrature {E[y, x] - quad:+.2e}")
    return lines


def plot(smith: dict, vcavity: dict, E: np.ndarray, E_avg: np.ndarray, out: str) -> None:
    """Six panels: E maps over (r, mu), difference maps, E_avg against r."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    extent = (-0.5 / 31, 1 + 0.5 / 31, -0.5 / 31, 1 + 0.5 / 31)  # node-centred cells
    fig, axes = plt.subplots(2, 3, figsize=(15, 9.2), constrained_layout=True)

    def draw(ax, values, title, cmap="viridis", limits=(0.3, 1.0)):
        image = ax.imshow(values, origin="lower", extent=extent, cmap=cmap, vmin=limits[0], vmax=limits[1],
                          aspect="auto", interpolation="nearest")
        ax.set(title=title, xlabel="r = sqrt(alpha)", ylabel="mu = cos(theta_i)")
        fig.colorbar(image, ax=ax)

    d_smith = smith["E_f1"] - E
    bound = max(np.max(np.abs(d_smith)), 1e-9)
    d_v = vcavity["E_f1"] - smith["E_f1"]
    span = np.max(np.abs(d_v))
    draw(axes[0, 0], E, "Cycles table_ggx_E (as shipped)")
    draw(axes[0, 1], smith["E_f1"], "vcavity, Smith microsurface: E_1")
    draw(axes[0, 2], d_smith, f"Smith E_1 - Cycles (max |d| {np.max(np.abs(d_smith)):.2g})", "RdBu_r",
         (-bound, bound))
    draw(axes[1, 0], vcavity["E_f1"], "vcavity, V-cavity microsurface: E_1")
    draw(axes[1, 1], d_v, f"V-cavity E_1 - Smith E_1 (max |d| {span:.2g})", "RdBu_r", (-span, span))
    ax = axes[1, 2]
    r = np.arange(32) / 31
    ax.plot(r, E_avg, "k-", lw=3, alpha=0.35, label="Cycles table_ggx_Eavg")
    ax.plot(r, smith["E_avg_f1"], "C0--", label="Smith E_avg,1")
    ax.plot(r, vcavity["E_avg_f1"], "C1-", label="V-cavity E_avg,1")
    ax.plot(r, smith["E_avg"], "C0:", label="Smith E_avg,inf")
    ax.plot(r, vcavity["E_avg"], "C1-.", label="V-cavity E_avg,inf")
    ax.set(title="E_avg = integral 2 mu E dmu", xlabel="r = sqrt(alpha)", ylim=(0.3, 1.02))
    ax.legend(loc="lower left")
    fig.suptitle("GGX, white mirror facets: single-scattering albedo E_1(mu, r) on Cycles' 32 x 32 nodes")
    fig.savefig(out, dpi=80)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("smith", help="--layout cycles .npz export of the Smith sweep")
    parser.add_argument("vcavity", help="--layout cycles .npz export of the V-cavity sweep")
    parser.add_argument("-o", "--output", default=None, help="PNG to write (default: none)")
    parser.add_argument("--check", type=int, default=0, metavar="K",
                        help="independent quadrature at the K largest differences (default 0)")
    args = parser.parse_args(argv)
    smith, vcavity = _load(args.smith), _load(args.vcavity)
    E, E_avg = cycles_tables.load()
    print(f"Cycles: {cycles_tables.SOURCE}")
    for line in report(smith, vcavity, E, E_avg):
        print(line)
    for line in check(smith, E, args.check):
        print(line)
    if args.output:
        plot(smith, vcavity, E, E_avg, args.output)
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
