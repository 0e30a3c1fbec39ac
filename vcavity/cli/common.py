"""Argument types, help text and error format of the ``vcavity`` command line.

Every bad flag is one line, ``vcavity: error: --seed = 'x': must be an integer >= 0 and
<= 18446744073709551615 (see vcavity run --help)``, exit status 2: the argument types
below say what is accepted, :meth:`_Parser.error` names the flag (issue 10, item 5).
"""

from __future__ import annotations

import argparse
import math
import re

EXIT_BAD_INPUT = 2

_RUN_EPILOG_TAIL = """\
  [incidence]  theta_i_deg = [0]   phi_i_deg = 0   paths = 10000000   (a config's defaults;
               the built-in run without CONFIG uses theta_i_deg = [0, 30, 60, 80])
               (phi_i_deg and paths: one value, or one per theta_i_deg; theta_i_deg in
               [0, 90), phi_i_deg in [-360, 360]; counts may be written 2e6)
  [simulation] seed = 1   max_order = 3   max_bounces = 10000
               track_all_orders = true   sensor_resolution = 57 (N x N cells)
               estimator = "analog" | "exact-f1" | "paper"   (default "analog")
               fold_symmetry = true | false   (default: fold wherever exact: isotropic
                 materials at phi_i a multiple of 45 deg, anisotropic at multiples of 90)
               target_error = E   max_paths = N   (optional: run each direction until the
                 energy-weighted relative standard error of f_inf is <= E, or N paths;
                 without max_paths the cap is incidence.paths)
  [output]     path = "table.h5" (relative to the config file; default: CONFIG with .h5)
               an existing table is replaced only with --overwrite; links, folders, FIFOs,
               devices and the config itself never are

conventions: macro normal +z; theta from +z, phi from +x toward +y; directions
point away from the surface. The table holds, per incident direction, bounce
order (0 = all orders, f_inf) and sensor cell, the cell-averaged cosine-weighted
BRDF in 1/sr with its standard error (docs/hdf5-format.md).

without CONFIG: the built-in default run, the IL paper's figure 7(b) material
(Beckmann alpha 0.6, kd 0.9, eta 1.5) at theta_i = 0, 30, 60, 80 degrees.
examples in runs/. The same config and seed give the same table for any
--threads and --chunk-blocks.
"""


def run_epilog() -> str:
    """``vcavity run --help`` epilog: config keys, generated from the registries."""
    from vcavity.facet import registry as facets
    from vcavity.microfacet import registry as distributions

    lines = ["config file (TOML):",
             f"  [material]   distribution = {' | '.join(repr(n) for n in distributions.NAMES)} "
             f"(default 'beckmann'), with its parameters:"]
    lines += [f"      {line}" for line in distributions.help_lines()]
    lines.append(f"               facet = {' | '.join(repr(n) for n in facets.NAMES)} "
                 "(default 'interfaced_lambertian'), with its parameters:")
    lines += [f"      {line}" for line in facets.help_lines()]
    return "\n".join(lines) + "\n" + _RUN_EPILOG_TAIL


def _count(lo: int, hi: int):
    """argparse type: an integer in [lo, hi]; integral floats (2e3) accepted, as in TOML."""
    accepted = f"must be an integer >= {lo} and <= {hi}"

    def parse(text: str) -> int:
        try:
            value = int(text.replace("_", ""))
        except ValueError:
            try:
                number = float(text)
            except ValueError:
                raise argparse.ArgumentTypeError(f"= {text!r}: {accepted}") from None
            if not (math.isfinite(number) and number == int(number)):
                raise argparse.ArgumentTypeError(f"= {text!r}: {accepted}") from None
            value = int(number)
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"= {text!r}: {accepted}")
        return value

    return parse


_PATHS_MAX = 2**62  # as config.MAX_PATHS (not imported: that would load the registries)


def _seed(text: str) -> int:
    """argparse type: a seed, as simulation.seed (decimal digits, 0 .. 2**64 - 1)."""
    if not re.fullmatch(r"[0-9][0-9_]*", text) or not 0 <= int(text.replace("_", "")) < 2**64:
        raise argparse.ArgumentTypeError(f"= {text!r}: must be an integer >= 0 and <= {2**64 - 1}")
    return int(text.replace("_", ""))


def _fraction(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"= {text!r}: expected a number in (0, 1)") from None
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"= {text!r}: expected a number in (0, 1)")
    return value


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose epilog may be a function, called only when help is shown.

    ``vcavity run --help`` lists every registered distribution and facet model; building
    that text imports the registries (and Numba), which ``vcavity info`` must not need.
    """

    def __init__(self, *args, epilog_factory=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._epilog_factory = epilog_factory

    def format_help(self):
        if self._epilog_factory is not None:
            self.epilog = self._epilog_factory()
            self._epilog_factory = None
        return super().format_help()

    def error(self, message):
        """One line, ``vcavity: error: --seed = 'x': ...``, exit status 2 (no usage dump)."""
        match = re.match(r"argument (?:-\w+/)?(-[-\w]+|[\w.]+): (.*)", message, re.DOTALL)
        if match:
            flag, rest = match.groups()
            message = f"{flag} {rest}" if rest.startswith("= ") else f"{flag}: {rest}"
        message = " ".join(message.split())
        self.exit(EXIT_BAD_INPUT, f"vcavity: error: {message} (see {self.prog} --help)\n")
