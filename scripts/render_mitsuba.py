"""Render a vcavity table through Mitsuba 3's own ``measured`` plugin (needs vcavity[render]).

Exports the table to an RGL ``.bsdf`` file (``vcavity export --format rgl``), then renders
a sphere with it twice: under a constant white environment (a white furnace: a lossless
f_inf table makes the sphere vanish into the background; f1 alone shows the missing
inter-reflected light as a darker sphere) and lit by one point light on a black
background. Writes ``<prefix>_environment.png`` and ``<prefix>_point.png`` (sRGB, no tone
mapping beyond clipping at 1) and prints the mean pixel value on the sphere.

    python scripts/render_mitsuba.py runs/fig7_eta1.5.h5 --order 0 -o fig7
    python scripts/render_mitsuba.py table.h5 --order 1 --spp 512 --resolution 256

Variant ``scalar_rgb`` (no LLVM needed); ``--variant llvm_ad_rgb`` is faster where a
working libLLVM is installed (Debian's LLVM 15 aborts with "Cannot select: fminimum").
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np


def build_scene(mi, bsdf_file: Path, light: str, resolution: int, spp: int):
    """A unit sphere seen by an orthographic camera along -z, lit by ``light``."""
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "orthographic",
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0])
                   @ mi.ScalarTransform4f().scale([1.15, 1.15, 1.0]),
                   "film": {"type": "hdrfilm", "width": resolution, "height": resolution,
                            "rfilter": {"type": "gaussian"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "sphere": {"type": "sphere", "bsdf": {"type": "measured", "filename": str(bsdf_file)}},
    }
    if light == "environment":
        scene["light"] = {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}}
    else:  # a point light up and to the right of the camera
        scene["light"] = {"type": "point", "position": [3.0, 3.0, 4.0], "intensity": {"type": "rgb", "value": 40.0}}
    return mi.load_dict(scene)


def save_png(image: np.ndarray, path: Path) -> None:
    """Linear RGB -> sRGB 8-bit PNG (values above 1 clip)."""
    import matplotlib.image

    linear = np.clip(image, 0.0, 1.0)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)
    matplotlib.image.imsave(path, srgb)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", help="a vcavity table (.h5) or an exported RGL file (.bsdf)")
    parser.add_argument("--order", default="0", help="bounce order to export from a table (0 = f_inf)")
    parser.add_argument("-o", "--output", default=None, help="prefix of the PNGs (default: the source's stem)")
    parser.add_argument("--spp", type=int, default=256, help="samples per pixel (default 256)")
    parser.add_argument("--resolution", type=int, default=256, help="image width = height in pixels")
    parser.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant (default scalar_rgb)")
    args = parser.parse_args(argv)
    try:
        import mitsuba as mi
    except ImportError:
        print("render_mitsuba: Mitsuba 3 is not installed: pip install 'vcavity[render]'", file=sys.stderr)
        return 2
    mi.set_variant(args.variant)
    source = Path(args.source)
    prefix = Path(args.output) if args.output else source.with_suffix("")
    with tempfile.TemporaryDirectory() as folder:
        bsdf_file = source
        if source.suffix != ".bsdf":
            from vcavity.cli import main as vcavity_main

            bsdf_file = Path(folder) / "table.bsdf"
            status = vcavity_main(["export", str(source), str(bsdf_file), "--format", "rgl", "--order", args.order])
            if status != 0:
                return status
        c = (np.arange(args.resolution) + 0.5) / args.resolution * 2.3 - 1.15
        on_sphere = (c[None, :] ** 2 + c[:, None] ** 2) < 0.95
        for light in ("environment", "point"):
            image = np.array(mi.render(build_scene(mi, bsdf_file, light, args.resolution, args.spp)))
            out = Path(f"{prefix}_{light}.png")
            save_png(image, out)
            print(f"wrote {out}: mean on the sphere {image[on_sphere].mean():.4f} "
                  f"(environment radiance 1)" if light == "environment" else
                  f"wrote {out}: mean on the sphere {image[on_sphere].mean():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
