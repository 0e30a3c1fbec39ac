"""Command-line interface: ``vcavity run``, ``info``, ``compare``, ``plot``, ``sweep``, ``export`` and ``warmup``.

Exit status: 0 success (compare: the test passed); 1 compare: the test failed; 2 bad input
(config, arguments, output path, unreadable table, model not applicable, not enough memory
or disk, a write that failed) with a one-line message and no output file; 130 interrupted
(Ctrl-C: one line, no output file written or changed); 143 terminated (SIGTERM, handled
as Ctrl-C).

Each subcommand is a module of this package with the same three names: ``NAME``,
``add_parser(subparsers)`` (its sub-parser, whose handler is its ``command``) and
``command(args) -> int``. They import :mod:`vcavity.cli.common` and lower layers, never
this package, so a new subcommand is a new module plus one entry in :data:`COMMANDS`.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

from vcavity.cli import compare, export, info, plot, run, sweep, warmup
from vcavity.cli.common import (EXIT_INTERRUPTED, EXIT_TERMINATED, Interrupted, Parser, forget_written,
                                written_outcome)

#: The subcommands, in the order ``vcavity --help`` lists them.
COMMANDS = (run, info, compare, plot, sweep, export, warmup)


def build_parser() -> argparse.ArgumentParser:
    """The ``vcavity`` argument parser (exposed for documentation and tests).

    Returns
    -------
    argparse.ArgumentParser
        The parser; ``parse_args`` sets ``command`` (the subcommand's name) and
        ``handler`` (its ``command`` function).
    """
    from vcavity._version import __version__

    parser = Parser(
        prog="vcavity",
        description="Monte-Carlo simulation of light in microfacet V-cavities: "
        "BRDF tables per bounce order (f1, f2, ..., f_inf) with error bars.",
    )
    parser.add_argument("--version", action="version", version=f"vcavity {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    subparsers.required = True
    for module in COMMANDS:
        module.add_parser(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``vcavity`` console script.

    Ctrl-C anywhere (compiling, tracing, writing, comparing) ends with one line on stderr
    and exit status 130, never a traceback; ``run`` leaves no table and an old one untouched.
    A command that knows what the interrupt left behind raises
    :class:`~vcavity.cli.common.Interrupted` saying so; the line then ends with that.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``vcavity`` (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status.
    """
    from vcavity.simulate import interrupts
    from vcavity.simulate.interrupts import is_interrupt

    args = argparse.Namespace()
    interrupts.reset()
    forget_written()
    interrupts.install_main_handler()
    restored_hook = sys.unraisablehook
    try:
        build_parser().parse_args(argv, namespace=args)
        status = args.handler(args)
        if status != EXIT_INTERRUPTED:
            interrupts.raise_if_pending()
        return EXIT_TERMINATED if status == EXIT_INTERRUPTED and interrupts.terminated() else status
    except BaseException as exc:
        # after a SIGINT that compiled code swallowed, what fails next (e.g. Numba's
        # "no compiled object yet") is a consequence of the interrupt, not a bug to show
        if not (is_interrupt(exc) or interrupts.pending()):
            raise
        # An interrupt inside Numba's compiler leaves half-built llvmlite objects whose
        # destructors complain at exit ("Exception ignored in ... ObjectRef.__del__"):
        # the process is ending on purpose, so such shutdown noise is not reported: the
        # silent hook stays installed after main returns, when those destructors run.
        sys.unraisablehook = restored_hook = _ignore_unraisable
        settled = exc.outcome if isinstance(exc, Interrupted) else written_outcome()
        outcome = f"; {settled}" if settled else ""
        notices = sys.modules.get("vcavity.simulate.warmup")  # (no notice without it)
        if notices is not None:
            notices.end_open_notices()  # the interrupt may have struck between a compile's end and its line's
        print(f"vcavity: interrupted{outcome}", file=sys.stderr)
        return EXIT_TERMINATED if interrupts.terminated() else EXIT_INTERRUPTED
    finally:
        sys.unraisablehook = restored_hook
        interrupts.uninstall_main_handler()


def _ignore_unraisable(unraisable) -> None:
    """``sys.unraisablehook`` after an interrupt: report nothing."""


def _late_interrupt(signum, frame) -> None:
    """A signal after :func:`main` returned: one line (what was written), exit 130 or 143."""
    settled = written_outcome()
    try:
        print(f"vcavity: interrupted{'; ' + settled if settled else ''}", file=sys.stderr, flush=True)
    except (OSError, ValueError):  # a closed stderr: nothing more can be said
        pass
    os._exit(EXIT_TERMINATED if signum == signal.SIGTERM else EXIT_INTERRUPTED)


class PipeSafe:
    """A text stream (stdout, stderr) whose reader may go away: ``vcavity info T.h5 | head -1``.

    When the reader has closed the pipe, writing raises ``BrokenPipeError`` (Python ignores
    SIGPIPE). Our output there is information only, never the result: the first broken
    write points the stream's file descriptor at ``os.devnull`` (what Python's docs advise
    for SIGPIPE) and everything after it is dropped silently, so the command carries on,
    a run writes its table, and the exit status is the command's own (0 once its work is
    done; ``compare`` its verdict), not 141: the reader chose to stop reading, which is no
    failure of the command (``set -o pipefail`` scripts piping into ``head`` stay green).

    Parameters
    ----------
    stream : io.TextIOWrapper
        The stream to guard (``sys.stdout`` or ``sys.stderr``).
    """

    def __init__(self, stream):
        self._stream = stream
        self.broken = False

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._divert()
            return len(text)

    def flush(self):
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._divert()
            self._stream.flush()  # what was buffered goes to devnull now

    def _divert(self):
        self.broken = True
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, self._stream.fileno())
        finally:
            os.close(devnull)

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _guard_streams() -> None:
    """Put :class:`PipeSafe` around ``sys.stdout`` and ``sys.stderr`` (real files only)."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        try:
            stream.fileno()
        except (AttributeError, OSError, ValueError):  # closed (None) or not a file: nothing to guard
            continue
        if not isinstance(stream, PipeSafe):
            setattr(sys, name, PipeSafe(stream))


def console_main() -> None:
    """The ``vcavity`` console script and ``python -m vcavity``: :func:`main`, then exit.

    The process ends with ``os._exit`` once stdout and stderr are flushed, skipping the
    interpreter's teardown: a Ctrl-C inside Numba's compiler can leave llvmlite objects
    half built, and their destructors at teardown have crashed the process (status -11
    after the "interrupted" line, seen once in CI); and during the teardown signals have
    their default actions again, so a late SIGTERM ended a finished command with 143 and
    no line. By then nothing of ours is pending: tables, checkpoints and temporary files
    were settled before :func:`main` returned, and a late Ctrl-C or SIGTERM before the
    exit gets its one line (:func:`_late_interrupt`).
    """
    _guard_streams()
    status = main()
    # From here on the outcome is settled: a late Ctrl-C or SIGTERM (while Dask's cluster
    # or the interpreter shuts down) ends the process at once with the same one line.
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _late_interrupt)
    for stream in (sys.stdout, sys.stderr):  # before the interpreter's teardown, which
        try:                                  # would report a broken pipe as "Exception ignored"
            stream.flush()
        except (OSError, ValueError, AttributeError):  # closed or None: nothing more can be said
            pass
    # os._exit whatever the status: the interpreter's teardown (Numba's and llvmlite's
    # objects, a few hundred ms) runs after Python has put the signals back to their
    # default actions, so a SIGTERM in it ended a finished run with 143 and no line (issue
    # 38 trial: 6 of 14 kills in that window). Nothing of ours waits for the teardown:
    # files are closed, the cluster shut down, the streams flushed above.
    os._exit(status)


if __name__ == "__main__":  # pragma: no cover
    console_main()
