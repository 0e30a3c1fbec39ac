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
"""

from __future__ import annotations

import contextlib
import os

try:
    import fcntl
except ImportError:  # not POSIX: no lock
    fcntl = None

from numba.core import caching


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
    if fcntl is None or not cache_location or index_file is None or not hasattr(index_file, "save"):
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


__all__ = ["install"]
