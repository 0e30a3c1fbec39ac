"""Ctrl-C that never lands inside compiled code or a half-written file.

Python runs a signal handler between bytecodes; when SIGINT arrives while a Numba kernel
runs, the default handler's ``KeyboardInterrupt`` surfaces as the kernel returns and
CPython reports ``SystemError: CPUDispatcher(...) returned a result with an exception
set``; inside h5py's Cython code it can be swallowed ("Exception ignored"), and the write
carries on. :class:`DeferredInterrupt` turns SIGINT into a flag instead, which the run
checks between kernel calls and the writer checks just before its rename, so an
interrupt always ends the same way: no table written, the old one untouched.
"""

from __future__ import annotations

import signal
import sys


_pending = False  # SIGINT seen by the main handler (possibly swallowed by a ctypes callback)
_terminated = False  # the interrupt was a SIGTERM: the command exits with 143, not 130


def _main_handler(signum, frame):
    global _pending
    _pending = True
    raise KeyboardInterrupt


def _unraisable(unraisable, _default=sys.unraisablehook):
    # A KeyboardInterrupt raised inside a ctypes callback of llvmlite (Numba compiling) is
    # "ignored" there and printed with a traceback: it is recorded in _pending instead and
    # acted on by raise_if_pending; after an interrupt, destructor noise is dropped too.
    if isinstance(unraisable.exc_value, KeyboardInterrupt) or _pending:
        return
    _default(unraisable)


def _term_handler(signum, frame):
    """SIGTERM is handled as Ctrl-C is at that moment (the current SIGINT handler: the main
    one raises, a :class:`DeferredInterrupt` sets its flag: checkpoint, one line, no
    temporary file) and remembered, so that the command exits with 143 (128 + SIGTERM)."""
    global _terminated, _pending
    _terminated = True
    handler = signal.getsignal(signal.SIGINT)
    if callable(handler):
        handler(signal.SIGINT, frame)
        return
    _pending = True  # SIGINT ignored (a background job) or default: a termination still ends the command
    raise KeyboardInterrupt


def install_main_handler() -> None:
    """SIGINT raises KeyboardInterrupt as usual and is remembered, even where compiled
    code swallows the exception (see :func:`raise_if_pending`); SIGTERM, where it has its
    default action, is handled as SIGINT (:func:`_term_handler`); main thread only."""
    try:
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, _main_handler)
            sys.unraisablehook = _unraisable
        if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            signal.signal(signal.SIGTERM, _term_handler)
    except ValueError:
        pass


def uninstall_main_handler() -> None:
    """Restore Python's default SIGINT handler where :func:`install_main_handler` set its own.

    Any other handler (a caller's, ``SIG_IGN``) is left alone; main thread only.
    """
    try:
        if signal.getsignal(signal.SIGINT) is _main_handler:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        if signal.getsignal(signal.SIGTERM) is _term_handler:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:
        pass


def raise_if_pending() -> None:
    """Raise ``KeyboardInterrupt`` if a SIGINT arrived that something swallowed."""
    if _pending:
        raise KeyboardInterrupt


def remember() -> None:
    """Record an interrupt that a :class:`DeferredInterrupt` caught where nothing polls it
    (e.g. while a cluster shuts down): :func:`raise_if_pending` then raises it."""
    global _pending
    _pending = True


def pending() -> bool:
    """Whether a SIGINT arrived under the main handler."""
    return _pending


def terminated() -> bool:
    """Whether the interrupt was a SIGTERM (handled as SIGINT; exit status 143)."""
    return _terminated


def reset() -> None:
    """Forget a remembered SIGINT or SIGTERM (for in-process callers such as tests)."""
    global _pending, _terminated
    _pending = _terminated = False


class DeferredInterrupt:
    """Context manager: SIGINT sets :attr:`requested` instead of raising; so does SIGTERM
    where :func:`install_main_handler` handles it (and it is remembered: exit status 143).

    SIGTERM is taken over on its own, not through the SIGINT handler: where SIGINT is ignored
    (a background job of a non-interactive shell, ``nohup``) a scheduler's or ``kill``'s
    SIGTERM must still end the run with its checkpoint, not raise in the middle of a kernel
    call. Outside the main thread nothing changes; a SIGINT ignored stays ignored. The
    previous handlers are restored on exit.
    """

    def __init__(self):
        self.requested = False
        self._previous = None
        self._previous_term = None

    def _handler(self, signum, frame):
        self.requested = True

    def _term(self, signum, frame):
        global _terminated
        _terminated = True
        self.requested = True

    def __enter__(self) -> "DeferredInterrupt":
        self.requested = _pending  # a SIGINT swallowed earlier (e.g. while compiling) counts
        try:
            previous = signal.getsignal(signal.SIGINT)
            if previous is not signal.SIG_IGN:
                signal.signal(signal.SIGINT, self._handler)
                self._previous = previous
            if signal.getsignal(signal.SIGTERM) is _term_handler:
                signal.signal(signal.SIGTERM, self._term)
                self._previous_term = _term_handler
        except ValueError:  # not the main thread: signals are not ours to handle
            self._previous = self._previous_term = None
        return self

    def __exit__(self, *exc_info) -> bool:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None
        if self._previous_term is not None:
            signal.signal(signal.SIGTERM, self._previous_term)
            self._previous_term = None
        return False

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` if SIGINT arrived (call it from plain Python code)."""
        if self.requested:
            raise KeyboardInterrupt

    def cancelled(self) -> bool:
        """Whether SIGINT arrived (the writer's ``cancelled`` hook)."""
        return self.requested


def is_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` is, or was caused by, a ``KeyboardInterrupt``.

    Covers the ``SystemError`` CPython raises when the default handler's exception is set
    while a compiled function returns (during the compile-time test call of a kernel).
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


__all__ = ["DeferredInterrupt", "is_interrupt"]
