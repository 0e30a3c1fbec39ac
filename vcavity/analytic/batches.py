"""Long model computations cut into short compiled calls, with a stop request between them.

A compiled (Numba) call cannot be interrupted: a signal handler runs only once it returns.
The analytic models behind the ``exact`` and ``exact-f1`` estimators would otherwise make
calls of tens of seconds on fine meshes (a 4096 x 4096 mesh of the every-order model: two
calls of 12 and 14 s on two cores), so Ctrl-C and SIGTERM waited for them. Their loops
over rows, cells or rays therefore run in batches (:func:`in_batches`) sized to take about
:data:`BATCH_SECONDS` each, and poll the caller's stop request (``should_stop``, a
callable returning True once the run is to stop) between batches and between passes,
raising :class:`ModelInterrupted`.

Batching never changes a result: every batched loop computes each item (a row of mesh
vertices, a chunk of rows, a cell, a ray) on its own and combines the items in a fixed
order, whatever the batch sizes, so the tables stay bit-identical.
"""

from __future__ import annotations

import time

#: Wall time one compiled call of a model aims at (s): a stop request waits at most about this.
BATCH_SECONDS = 0.25
#: How much a batch may grow from one call to the next (a call far shorter than the aim,
#: e.g. the first after a cache load, must not make the next one huge).
MAX_GROWTH = 4


class ModelInterrupted(KeyboardInterrupt):
    """A model's computation stopped on its caller's stop request (between two batches).

    A ``KeyboardInterrupt``: whoever handles Ctrl-C handles it (a sweep keeps its
    finished points); a run turns it into its own interrupted path.
    """

    def __init__(self):
        super().__init__("model computation interrupted")


def check_stop(should_stop) -> None:
    """Raise :class:`ModelInterrupted` when ``should_stop`` (a callable or None) says so."""
    if should_stop is not None and should_stop():
        raise ModelInterrupted


def in_batches(total: int, first: int, run, should_stop=None, seconds: float = BATCH_SECONDS,
               minimum: int = 1, maximum: int | None = None) -> None:
    """Call ``run(start, stop)`` over consecutive ranges covering ``[0, total)``, in order.

    The first range holds ``first`` items; each later one is resized so that a call takes
    about ``seconds`` (from the last call's time per item; at most :data:`MAX_GROWTH`
    times the last size, at least ``minimum`` items). ``should_stop`` is polled before
    every call (:func:`check_stop`).

    Parameters
    ----------
    total, first : int
        Items in all, and in the first call.
    run : callable
        ``run(start, stop)`` computes items ``start .. stop - 1``.
    should_stop : callable, optional
        The stop request.
    seconds : float
        Aimed wall time of a call.
    minimum : int
        Fewest items per call (e.g. the number of threads, so that a call keeps them busy).
    maximum : int, optional
        Most items per call (a bound on memory); at least ``minimum``.

    Raises
    ------
    ModelInterrupted
        The stop request came; the items before it are computed.
    """
    lowest = max(int(minimum), 1)
    highest = max(int(maximum), lowest) if maximum is not None else None
    start = 0
    size = max(int(first), lowest)
    while start < total:
        if highest is not None:
            size = min(size, highest)
        check_stop(should_stop)
        stop = min(total, start + size)
        t0 = time.perf_counter()
        run(start, stop)
        elapsed = time.perf_counter() - t0
        done = stop - start
        wanted = done * seconds / elapsed if elapsed > 0.0 else done * MAX_GROWTH
        size = max(lowest, min(int(wanted), MAX_GROWTH * done))
        start = stop


__all__ = ["BATCH_SECONDS", "ModelInterrupted", "check_stop", "in_batches"]
