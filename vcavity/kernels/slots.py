"""A walk's thread slots run at once, on a pool of Python threads kept between calls.

A compiled walk traces the blocks of one thread slot (:mod:`vcavity.kernels.loop`) with
the GIL released (``nogil=True``): :func:`run_slots` runs the slots of one call at once,
slot 0 in the calling thread and the others on a pool of threads. Threads rather than
Numba's ``prange`` in a ``parallel=True`` kernel: the parallel loop's passes and lowering
were a third of each variant's cold compile, and the walks are as fast (docs/performance.md,
"Compile time: slots on Python threads").
"""

from __future__ import annotations

import concurrent.futures
import os
import threading
from concurrent.futures import ThreadPoolExecutor

# The slots' threads, kept between calls: a pool made and shut down per call costs twice as
# much a call as waking a sleeping thread and hearing back (docs/performance.md, "Figures
# from the code's comments").
# Threads are made as slots need them (up to _MAX_SLOT_THREADS) and sleep when idle; a
# forked child starts a pool of its own (the parent's threads do not exist there).
_MAX_SLOT_THREADS = 1024
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


def _slot_pool() -> ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max_workers=_MAX_SLOT_THREADS, thread_name_prefix="vcavity-slot")
        return _pool


def _forget_pool() -> None:
    global _pool, _pool_lock
    _pool, _pool_lock = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool)


def run_slots(walk_slot, n_slots: int, compiled: bool) -> None:
    """``walk_slot(s)`` for ``s`` in ``range(n_slots)``, concurrently; slot 0 in this thread.

    The other slots run on a pool of threads kept between calls. A walk not yet compiled
    (or loaded from the cache) in this process runs slot 0 first, alone: the compile
    happens once, in the calling thread, where the compile notice and Ctrl-C work as for
    any call (:class:`vcavity.simulate.warmup.CompileNotice`). Returns when every slot
    has; an exception in one is raised here after the others end.
    """
    if n_slots < 1:
        return
    if n_slots == 1:
        walk_slot(0)
        return
    if not compiled:
        walk_slot(0)
    futures = [_slot_pool().submit(walk_slot, slot) for slot in range(1, n_slots)]
    try:
        if compiled:
            walk_slot(0)
    finally:
        # every slot ends before this returns or raises: no walk outlives its call's arrays
        concurrent.futures.wait(futures)
    for future in futures:
        future.result()


__all__ = ["run_slots"]
