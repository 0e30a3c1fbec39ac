"""The vocabulary every ``vcavity`` subcommand shares: exit codes, errors, argument types.

Every bad flag is one line, ``vcavity: error: --seed = 'x': must be an integer >= 0 and
<= 18446744073709551615 (see vcavity run --help)``, exit status 2: the argument types
below say what is accepted, :meth:`Parser.error` names the flag. Every other bad input
(a config, an output path, an unreadable table) is one line too, printed by :func:`error`.

This module imports nothing of ``vcavity`` at import time: ``vcavity info`` and
``--help`` must not load the registries or Numba.
"""

from __future__ import annotations

import argparse
import math
import re
import sys

EXIT_OK = 0
EXIT_TEST_FAILED = 1  # compare: the chi-square test rejected the model
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a Ctrl-C
EXIT_TERMINATED = 143  # 128 + SIGTERM: handled as Ctrl-C, reported as the signal it was


class BadInput(Exception):
    """Input the command refuses; its message is the whole one-line error."""


class Interrupted(KeyboardInterrupt):
    """A Ctrl-C, raised on by a command that knows what it left behind.

    Parameters
    ----------
    outcome : str
        Words after ``vcavity: interrupted; ``, e.g. ``"no table written"``.
    """

    def __init__(self, outcome: str):
        super().__init__(outcome)
        self.outcome = outcome


_WRITTEN: list[str] = []  # outputs this command has completed (what a late Ctrl-C reports)


def written(path) -> None:
    """Record that the command's output ``path`` is complete.

    A Ctrl-C (or SIGTERM) from then on, still in the command or while the process shuts
    down (Dask's cluster, flushing), is reported as ``vcavity: interrupted; the output
    was written: PATH`` with exit status 130 (143), as ``run`` reports its table.

    Parameters
    ----------
    path : str or os.PathLike
    """
    _WRITTEN.append(str(path))


def written_outcome() -> str | None:
    """The words after ``vcavity: interrupted; `` once an output is complete, else None."""
    return f"the output was written: {', '.join(_WRITTEN)}" if _WRITTEN else None


def forget_written() -> None:
    """Start a command with nothing written (:func:`main` calls it; tests run in-process)."""
    _WRITTEN.clear()


def error(message) -> int:
    """Print the one-line error ``vcavity: error: MESSAGE`` on stderr.

    Parameters
    ----------
    message : str or BadInput
        What was wrong, naming the flag, field or file.

    Returns
    -------
    int
        :data:`EXIT_BAD_INPUT`, the command's exit status.
    """
    print(f"vcavity: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def first_line(exc: BaseException, fallback: str | None = None) -> str:
    """The first line of an exception's message, for a one-line error.

    Parameters
    ----------
    exc : BaseException
        The exception; its message may span lines (h5py, Numba, Dask) or be empty.
    fallback : str, optional
        Returned when the message is empty; default: the exception's type name.

    Returns
    -------
    str
        The first line (possibly empty when the message starts with a newline).
    """
    text = str(exc)
    if text:
        return text.splitlines()[0]
    return type(exc).__name__ if fallback is None else fallback


def open_table_or_error(path: str, sweeps: bool = False):
    """Open the table at ``path``, or print why it cannot be read.

    Parameters
    ----------
    path : str
        The path as the user typed it (the error quotes it).
    sweeps : bool, default False
        Also accept a sweep file (``vcavity sweep``), opened as one.

    Returns
    -------
    Table, SweepTable or None
        The opened file, or None after the one-line error was printed (the caller then
        exits with :data:`EXIT_BAD_INPUT`).
    """
    from pathlib import Path

    from vcavity.io.table import TableFormatError, open_table

    unreadable: tuple[type[BaseException], ...] = (TableFormatError, OSError)
    if sweeps:  # imported only when asked: compare and export need no sweep reader
        from vcavity.io.sweep_table import SweepFormatError, is_sweep_file, open_sweep

        unreadable += (SweepFormatError,)
    try:
        # only regular files are probed for a sweep: h5py blocks on a FIFO
        if sweeps and Path(path).is_file() and is_sweep_file(path):
            return open_sweep(path)
        return open_table(path)
    except FileNotFoundError:
        error(f"table {path!r}: no such file")
    except unreadable as exc:
        error(first_line(exc, f"table {path!r}: cannot read it"))
    return None


_RUN_EPILOG_TAIL = """\
  [incidence]  theta_i_deg = [0]   phi_i_deg = 0   paths = 10000000   (a config's defaults;
               the built-in run without CONFIG uses theta_i_deg = [0, 30, 60, 80])
               (phi_i_deg and paths: one value, or one per theta_i_deg; theta_i_deg in
               [0, 90), phi_i_deg in [-360, 360]; counts may be written 2e6)
  [simulation] seed = 1   max_order = 3   max_bounces = 10000
               track_all_orders = true   sensor_resolution = 57 (N x N cells)
               estimator = {estimators}   (default {default})
               fold_symmetry = true | false   (default: fold wherever exact: isotropic
                 materials at phi_i a multiple of 45 deg, anisotropic at multiples of 90)
               target_error = E   max_paths = N   (optional: run each direction until the
                 energy-weighted relative standard error of f_inf is <= E, or N paths;
                 without max_paths the cap is incidence.paths)
               device = 'cpu' | 'cuda'   (default 'cpu'; 'cuda': the walk on an NVIDIA
                 GPU, needs vcavity[cuda]; not the paper estimator; with --dask, one worker
                 per GPU; docs/gpu.md)
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
    """``vcavity run --help`` epilog: config keys, generated from the registries.

    Returns
    -------
    str
        The epilog, every registered distribution and facet model with its parameters.
    """
    from vcavity.facet import registry as facets
    from vcavity.microfacet import registry as distributions

    walkable = [n for n in distributions.NAMES if distributions.smith_walk_refusal(n) is None]
    lines = ["config file (TOML):",
             "  [material]   microsurface = 'v-cavity' | 'smith' (default 'v-cavity': V-grooves; 'smith': "
             "Smith's random walk,",
             f"               Heitz et al. 2016, for {', '.join(walkable)}, analog or exact-f1 estimator; physics.md sec. 15)",
             f"               distribution = {' | '.join(repr(n) for n in distributions.NAMES)} "
             f"(default 'beckmann'), with its parameters:"]
    lines += [f"      {line}" for line in distributions.help_lines()]
    lines.append(f"               facet = {' | '.join(repr(n) for n in facets.NAMES)} "
                 "(default 'interfaced_lambertian'), with its parameters:")
    lines += [f"      {line}" for line in facets.help_lines()]
    from vcavity.estimators import registry as estimators

    tail = _RUN_EPILOG_TAIL.replace("{estimators}", " | ".join(repr(n) for n in estimators.names())).replace(
        "{default}", repr(estimators.default()))
    return "\n".join(lines) + "\n" + tail


PATHS_MAX = 2**62  # as config.MAX_PATHS (not imported: that would load the registries)


def count_arg(lo: int, hi: int):
    """An argparse type: an integer in ``[lo, hi]``; integral floats (2e3) accepted, as in TOML.

    Parameters
    ----------
    lo, hi : int
        The smallest and largest accepted value.

    Returns
    -------
    callable
        ``parse(text) -> int``, raising ``argparse.ArgumentTypeError`` with the range.
    """
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


def seed_arg(text: str) -> int:
    """An argparse type: a seed, as simulation.seed (decimal digits, 0 .. 2**64 - 1).

    Parameters
    ----------
    text : str
        The flag's value.

    Returns
    -------
    int
        The seed.
    """
    if not re.fullmatch(r"[0-9][0-9_]*", text) or not 0 <= int(text.replace("_", "")) < 2**64:
        raise argparse.ArgumentTypeError(f"= {text!r}: must be an integer >= 0 and <= {2**64 - 1}")
    return int(text.replace("_", ""))


def _number_arg(text: str, accepted, expected: str, prefix: str = "= ") -> float:
    """``float(text)`` if ``accepted`` of it, else the one-line ``ArgumentTypeError``."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan  # refused below: no predicate accepts NaN
    if not accepted(value):
        raise argparse.ArgumentTypeError(f"{prefix}{text!r}: {expected}")
    return value


def fraction_arg(text: str) -> float:
    """An argparse type: a number strictly between 0 and 1 (``text``: the flag's value)."""
    return _number_arg(text, lambda value: 0.0 < value < 1.0, "expected a number in (0, 1)")


def seconds_arg(text: str) -> float:
    """An argparse type: a finite number of seconds > 0 (``text``: the flag's value)."""
    # no leading "= " (unlike the types above): Parser.error then writes the line as
    # "--checkpoint-every: '-1': expected ...", the form the tests pin
    return _number_arg(text, lambda value: value > 0 and math.isfinite(value),
                       "expected a number of seconds > 0", prefix="")


class Parser(argparse.ArgumentParser):
    """ArgumentParser whose epilog may be a function, called only when help is shown.

    ``vcavity run --help`` lists every registered distribution and facet model; building
    that text imports the registries (and Numba), which ``vcavity info`` must not need.
    """

    def __init__(self, *args, epilog_factory=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._epilog_factory = epilog_factory

    def format_help(self):
        """The help text, with the epilog built now if it is a function."""
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
