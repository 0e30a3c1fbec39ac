"""Numba's on-disk cache, made safe for read-only installs.

Every jitted function of vcavity is decorated with :func:`njit` from here, never with
``numba.njit`` directly. Numba looks for a cache directory when a ``cache=True`` function
is *decorated*, and raises ``RuntimeError: cannot cache function ...: no locator
available`` when it finds none (an install that the user cannot write, with an
unwritable home). This module decides once, at import, where the cache goes:

1. wherever Numba itself would put it: ``NUMBA_CACHE_DIR`` when set, else the
   ``__pycache__`` folders beside the sources, else Numba's per-user cache directory;
2. if none of those is writable, a private per-user folder in the temporary directory
   (``<tmp>/vcavity-numba-cache-<uid>``, mode 0700, used only when it is ours; ``<tmp>``
   is ``TMPDIR`` when set, else the system's);
3. if even that fails, no caching: kernels are compiled in every process, and a one-line
   note says so on stderr.

Nothing here changes what is computed; only where compiled code is kept.
"""

from __future__ import annotations

import os
import sys
import tempfile

import numba
from numba.core.caching import FunctionCache


def _probe():  # a function in this package's folder: the in-tree cache is tried for it
    return None


def _cache_locatable() -> bool:
    """True when Numba finds a writable cache location for a function of this package."""
    try:
        FunctionCache(_probe)
    except RuntimeError:
        return False
    return True


def _temporary_directory() -> str:
    """The temporary directory the user chose (``TMPDIR``, ``TEMP`` or ``TMP``), else the system's.

    ``tempfile.gettempdir()`` silently replaces a chosen directory it cannot write with
    ``/tmp`` (or even the working directory); compiled code is not put somewhere the user
    did not choose, so a chosen directory is used as it is.
    """
    for name in ("TMPDIR", "TEMP", "TMP"):
        if os.environ.get(name):
            return os.environ[name]
    return tempfile.gettempdir()


def _private_temporary_cache() -> str | None:
    """``<tmp>/vcavity-numba-cache-<uid>``, created 0700; None if not usable or not ours."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    path = os.path.join(_temporary_directory(), f"vcavity-numba-cache-{uid}")
    try:
        os.mkdir(path, 0o700)  # only the leaf: never create a missing temporary directory
    except FileExistsError:
        pass
    except OSError:
        return None
    try:
        info = os.lstat(path)
    except OSError:
        return None
    if not os.path.isdir(path) or os.path.islink(path) or (hasattr(os, "getuid") and info.st_uid != uid):
        return None  # somebody else's folder (or a symlink): never cache there
    return path if os.access(path, os.W_OK | os.X_OK) else None


def _choose_cache() -> tuple[bool, str]:
    """(caching enabled, where) for this process."""
    if _cache_locatable():
        return True, numba.config.CACHE_DIR or "numba default (beside the sources or per user)"
    fallback = _private_temporary_cache()
    if fallback is not None:
        numba.config.CACHE_DIR = fallback
        if _cache_locatable():
            return True, fallback
        numba.config.CACHE_DIR = ""
    print("vcavity: note: no writable Numba cache directory (set NUMBA_CACHE_DIR to one); "
          "kernels are compiled in every process", file=sys.stderr)
    return False, ""


CACHE_ENABLED, CACHE_LOCATION = _choose_cache()


def njit(*args, **options):
    """``numba.njit`` with ``cache=True`` honoured only where a cache can be written.

    Parameters
    ----------
    *args, **options
        As for :func:`numba.njit`.

    Returns
    -------
    numba dispatcher or decorator
        Exactly what ``numba.njit`` returns.
    """
    if options.get("cache") and not CACHE_ENABLED:
        options["cache"] = False
    return numba.njit(*args, **options)


__all__ = ["njit", "CACHE_ENABLED", "CACHE_LOCATION"]
