"""The vocabulary of a plot request: what was asked, checked once, before anything is drawn.

Every plot kind (:mod:`vcavity.plots.slice`, ``map``, ``albedo``, ``sweep``) checks its
options with these helpers and answers with a :class:`PlotRequest`; a bad option is a
one-line :class:`PlotError` naming the option, the value and what is accepted.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

OUTPUT_SUFFIXES = (".png", ".pdf", ".svg")


class PlotError(ValueError):
    """A plot request the table cannot satisfy; the message is one line."""


class ImageNotWritten(Exception):
    """Saving the image failed (a full disk, ...); nothing was written, no temporary file left.

    Attributes
    ----------
    reason : str
        What the system said (``No space left on device``), for a one-line message.
    """

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class PlotRequest:
    """A checked request: what :func:`render` draws."""

    kind: str
    output: Path
    indices: tuple
    orders: tuple
    scale: str
    models: tuple


def parse_order(text) -> int:
    """Bounce order from ``"0"``, ``"inf"``, ``"f_inf"``, ``"2"`` or ``"f2"``.

    Raises
    ------
    PlotError
        If ``text`` names no order.
    """
    word = str(text).strip().lower()
    if word in ("inf", "f_inf", "finf", "0"):
        return 0
    digits = word[1:] if word.startswith("f") else word
    if digits.isdigit():
        return int(digits)
    raise PlotError(f"--order = {text!r}: expected a bounce order: 1, 2, ... (or f1, f2, ...), "
                    "or 0 / inf / f_inf for all orders")


def default_output(table, kind: str) -> Path:
    """``<table stem>_<kind>.png`` beside the table."""
    return table.path.with_name(f"{table.path.stem}_{kind}.png")


def check_output(output, overwrite: bool = False, source=None, field: str = "-o") -> Path:
    """The output image as a path, refused (PlotError) unless it may be written.

    The output rules of ``vcavity run`` and ``export`` (:func:`vcavity.io.preflight.check_output`):
    never a link, FIFO, device, folder or the input ``source`` itself; an existing file only
    with ``overwrite``; the folder must accept a new file. Stale temporary files of killed
    plots are removed.

    Parameters
    ----------
    output : str or os.PathLike
    overwrite : bool
        Replace an existing file (``--overwrite``).
    source : str or os.PathLike, optional
        The table or sweep file drawn.
    field : str
        How the user named the output, for messages: ``-o``, or the default.
    """
    from vcavity.io import preflight

    out = preflight.Output(Path(output), field, str(output))
    if out.path.suffix.lower() not in OUTPUT_SUFFIXES:
        raise PlotError(f"{field} = {str(out.path)!r}: unsupported file type {out.path.suffix or '(none)'!r}; "
                        f"accepted {', '.join(OUTPUT_SUFFIXES)}")
    try:
        preflight.check_output(out, None, overwrite, source=None if source is None else os.fspath(source))
        preflight.probe_output(out)
    except preflight.PreflightError as exc:
        raise PlotError(str(exc)) from None
    return out.path


def default_field(kind: str) -> str:
    """How messages name the default output of ``kind``."""
    return f"output (default: <input>_{kind}.png beside the input)"


def save(fig, output: Path, dpi: int = 110, cancelled=None) -> None:
    """Save ``fig`` to ``output`` atomically (temporary file in the same folder, os.replace);
    ``cancelled`` as in :func:`vcavity.io.atomic.replace_atomically`.

    Raises
    ------
    ImageNotWritten
        The system refused the write (disk full, quota, I/O error): ``output`` is untouched
        and the temporary file removed.
    """
    import io

    from vcavity.io.atomic import replace_atomically, write_bytes

    # drawn into memory first: matplotlib's PDF backend, failing to write mid-stream,
    # raises an AttributeError from its cleanup instead of the OSError; plain file I/O
    # then writes the bytes (the temporary file ends in .tmp: the format comes from the
    # output's suffix)
    image = io.BytesIO()
    fig.savefig(image, format=output.suffix[1:].lower(), dpi=dpi)
    try:
        replace_atomically(output, lambda temporary: write_bytes(temporary, image.getvalue()), cancelled=cancelled)
    except OSError as exc:
        raise ImageNotWritten(exc.strerror or str(exc).splitlines()[0]) from None


def sort_orders(orders) -> tuple:
    """Orders as drawn: f1, f2, ..., then f_inf (order 0) last."""
    return tuple(sorted(orders, key=lambda k: (k == 0, k)))


def select_theta(theta_deg, requested, source: str) -> list:
    """Indices of the incident directions ``--theta-i`` names (all when ``requested`` is empty).

    ``requested`` holds strings or numbers in degrees, matched within 1e-6 deg of the
    tabulated ``theta_deg`` (every direction at a matching angle, in order, once).

    Raises
    ------
    PlotError
        A value that is not a number or matches no tabulated angle (``source`` names the
        file in the message, which lists the tabulated angles).
    """
    theta = np.asarray(theta_deg, dtype=np.float64)
    if not requested:
        return list(range(theta.size))
    indices = []
    for value in requested:
        try:
            number = float(value)
        except ValueError:
            raise PlotError(f"--theta-i = {value!r}: expected an angle in degrees") from None
        hits = np.flatnonzero(np.isclose(theta, number, rtol=0.0, atol=1e-6))
        if hits.size == 0:
            listed = ", ".join(f"{t:g}" for t in theta)
            raise PlotError(f"--theta-i = {number:g}: not an incident direction of {source} "
                            f"(theta_i_deg: {listed})")
        indices.extend(int(h) for h in hits if int(h) not in indices)
    return indices
