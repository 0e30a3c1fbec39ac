"""Exclusive writes to Numba's cache index in vcavity's cache folder, across processes.

Numba keeps, per cached function, an index (signature -> data file) and one data file per
compiled signature. Its ``IndexDataCacheFile.save`` (numba/core/caching.py) loads the
index, picks the first data-file number not in it, writes the index, then the data, with
no lock; ``load`` reads the index, then the data file it names, without checking the key.
Two processes saving *different* signatures of one function at once (two warm-ups, two
Dask workers, two test workers on one cache) can both pick the same number: the index then
maps one signature to a data file holding the other's code, and a later load runs the wrong
specialisation. Each kernel variant has a function name, so an index, of its own; the
analytic functions specialised per kind with ``literally`` share one index per function.

:func:`install` wraps ``save`` in an exclusive and ``load`` in a shared ``fcntl.flock`` on
``<index>.lock``, for index files inside vcavity's own cache folder only (other packages'
caches are left as Numba writes them). Where ``flock`` is unavailable (not POSIX) or the
lock file cannot be opened, Numba's own behaviour stands.

A save that the disk refuses (full, over quota, read-only, no permission: :data:`REFUSED`)
does not end the process with Numba's traceback: the code just compiled runs from memory,
the failure is said once per process in one line on stderr (the folder, the reason, what to
do) and recorded in :data:`SAVE_FAILURES` (``vcavity warmup``, whose work is the saving,
turns it into an error). Numba writes each index and data file through a temporary file
and a rename, so a failed save leaves no half-written file: the next process compiles
again where this one could not save.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sys

try:
    import fcntl
except ImportError:  # not POSIX: no lock
    fcntl = None

from numba.core import caching

#: The errors of a disk that cannot take a save: full, over quota, read-only, refused.
REFUSED = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM})
#: ``(cache folder, reason)`` of each save refused in this process, in order.
SAVE_FAILURES: list[tuple[str, str]] = []


_held = 0  # notes_held() depth
_deferred: list[str] = []


@contextlib.contextmanager
def notes_held(say: bool = True):
    """Hold the refused-save note until the block ends (a compile notice's line is open in
    it), then say it, or with ``say=False`` drop it (the caller reports the failure itself)."""
    global _held
    _held += 1
    try:
        yield
    finally:
        _held -= 1
        if not _held:
            for line in _deferred if say else ():
                print(line, file=sys.stderr)
            _deferred.clear()


def _save_refused(folder: str, exc: OSError) -> None:
    """Record a refused save; the first of the process is said in one line."""
    reason = exc.strerror or type(exc).__name__
    if not SAVE_FAILURES:
        line = (f"vcavity: note: the Numba cache folder {folder!r} cannot take compiled code ({reason}): "
                f"compiling in this process only, the next run compiles again (free space there, or set "
                f"NUMBA_CACHE_DIR to a folder that can)")
        if _held:
            _deferred.append(line)
        else:
            print(line, file=sys.stderr)
    SAVE_FAILURES.append((folder, reason))


@contextlib.contextmanager
def _flocked(index_path: str, exclusive: bool):
    """``flock`` on ``index_path + ".lock"`` for the block (nothing when it cannot be had)."""
    try:
        handle = open(index_path + ".lock", "a")
    except OSError:
        yield
        return
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        except OSError:  # a file system without flock (some NFS): Numba's own behaviour
            yield
            return
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def install(cache_location: str, module=caching) -> bool:
    """Make Numba's index saves exclusive (and loads shared) under ``cache_location``.

    Parameters
    ----------
    cache_location : str
        vcavity's cache folder (:data:`vcavity._numba.jit.CACHE_LOCATION`); "" installs nothing.
    module : module
        The caching module whose ``IndexDataCacheFile`` is wrapped: Numba's
        (``numba.core.caching``, the default), or numba-cuda's, which has a class of its own
        (``numba.cuda.core.caching``, :mod:`vcavity.kernels.cuda_loop`).

    Returns
    -------
    bool
        True when installed (now or by an earlier call).
    """
    index_file = getattr(module, "IndexDataCacheFile", None)
    if not cache_location:
        return False
    _guard_saves(getattr(module, "Cache", None), os.path.join(os.path.abspath(cache_location), ""))
    if fcntl is None or index_file is None or not hasattr(index_file, "save"):
        return False
    if getattr(index_file.save, "_vcavity_locked", False):
        return True
    root = os.path.join(os.path.abspath(cache_location), "")
    plain_save, plain_load = index_file.save, index_file.load

    def ours(self) -> bool:
        return os.path.abspath(self._index_path).startswith(root)

    def save(self, key, data):
        if not ours(self):
            return plain_save(self, key, data)
        with _flocked(self._index_path, exclusive=True):
            return plain_save(self, key, data)

    def load(self, key):
        if not ours(self):
            return plain_load(self, key)
        with _flocked(self._index_path, exclusive=False):
            return plain_load(self, key)

    save._vcavity_locked = True
    index_file.save, index_file.load = save, load
    return True


def _guard_saves(cache_class, root: str) -> None:
    """Wrap ``cache_class.save_overload`` (Numba's or numba-cuda's ``Cache``): a save under
    ``root`` that the disk refuses (:data:`REFUSED`) is said and recorded, not raised."""
    plain = getattr(cache_class, "save_overload", None)
    if plain is None or getattr(plain, "_vcavity_guarded", False):
        return

    def save_overload(self, sig, data):
        try:
            return plain(self, sig, data)
        except OSError as exc:
            folder = os.path.abspath(getattr(self, "_cache_path", ""))
            if exc.errno not in REFUSED or not os.path.join(folder, "").startswith(root):
                raise
            _save_refused(root.rstrip(os.sep), exc)

    save_overload._vcavity_guarded = True
    cache_class.save_overload = save_overload


__all__ = ["REFUSED", "SAVE_FAILURES", "install", "notes_held"]
