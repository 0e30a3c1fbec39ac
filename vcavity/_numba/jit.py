"""Numba's on-disk cache: one per-user folder of vcavity's own, never inside the install.

Every jitted function of vcavity is decorated with :func:`njit` from here, never with
``numba.njit`` directly. Left to itself, Numba caches ``cache=True`` functions in the
``__pycache__`` folders beside their sources: for a regular install that is
``site-packages/vcavity/*/__pycache__``, files pip does not know about, which outlive
``pip uninstall`` and leave a ``vcavity`` namespace folder that shadows a later install.
So this module decides once, at import, where vcavity's compiled code goes:

1. ``NUMBA_CACHE_DIR`` (``numba.config.CACHE_DIR``) when the user set it;
2. else a per-user cache folder keyed by vcavity's version, :func:`user_cache_dir`:
   ``$XDG_CACHE_HOME/vcavity/<version>/numba`` (``~/.cache/...`` when unset) on Linux,
   ``~/Library/Caches/vcavity/<version>/numba`` on macOS,
   ``%LOCALAPPDATA%\\vcavity\\Cache\\<version>\\numba`` on Windows;
   (when the folder ``NUMBA_CACHE_DIR`` names cannot be used: a one-line note on stderr, and
   the next folder here; ``vcavity warmup`` refuses instead, :data:`NAMED_CACHE_REFUSED`);
3. if that cannot be written (a read-only home), a private folder in the temporary
   directory (``<tmp>/vcavity-numba-cache-<uid>``, mode 0700, used only when it is ours;
   ``<tmp>`` is ``TMPDIR`` when set, else the system's);
4. if even that fails, no caching: kernels are compiled in every process, and a one-line
   note says so on stderr.

The folder is applied to vcavity's functions only: ``numba.config.CACHE_DIR`` is set
while :func:`njit` decorates (Numba fixes a function's cache folder then, when it builds
the function's cache locator) and restored right after, so other packages' Numba caches
and child processes' environments are untouched, and the order in which Numba and
vcavity are imported does not matter. Within the folder Numba keeps one subfolder per
source folder (its name and a hash of its path), and names its files after the function
and the Python version, and checks Numba's version and the source file's time stamp on
load; so one folder serves several installs, Pythons and Numbas without mix-ups. The
version key lets an upgrade start clean and ``rm -rf`` of an old version's folder free
its space. Nothing here changes what is computed; only where compiled code is kept.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading

import numba

from vcavity._numba import cache_lock
from vcavity._version import __version__


def user_cache_dir(environ=None, platform: str | None = None) -> str | None:
    """The per-user folder for vcavity's compiled code under the platform's cache rules.

    The XDG base directory rule on Linux and other Unixes, ``~/Library/Caches`` on macOS,
    ``%LOCALAPPDATA%`` on Windows (the rules ``platformdirs.user_cache_dir`` follows; the
    few lines here spare a dependency).

    Parameters
    ----------
    environ : mapping, optional
        Environment variables (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` value (default: this one's).

    Returns
    -------
    str or None
        ``<cache home>/vcavity/<version>/numba``; None when there is no home to put it in.
    """
    environ = os.environ if environ is None else environ
    platform = sys.platform if platform is None else platform
    home = environ.get("HOME") or os.path.expanduser("~")
    if platform.startswith("win"):
        base = environ.get("LOCALAPPDATA")
        return os.path.join(base, "vcavity", "Cache", __version__, "numba") if base else None
    if platform == "darwin":
        base = os.path.join(home, "Library", "Caches")
    else:
        base = environ.get("XDG_CACHE_HOME", "")
        if not os.path.isabs(base):  # the XDG rule: a relative path is invalid and ignored
            base = os.path.join(home, ".cache")
    if not os.path.isabs(base):  # no home at all ("~" unexpanded)
        return None
    return os.path.join(base, "vcavity", __version__, "numba")


def _writable_folder(path: str) -> bool:
    """Whether ``path`` is, or can be made, a folder this process can write files in."""
    return _unwritable_because(path) is None


def _unwritable_because(path: str) -> str | None:
    """Why ``path`` cannot hold this process's files (one phrase), or None when it can.

    The same test as Numba's own (create the folders, then a temporary file there).
    """
    try:
        os.makedirs(path, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as error:
        return error.strerror or type(error).__name__
    return None


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
    return path if _writable_folder(path) else None


def _choose_cache() -> tuple[str, str]:
    """``(folder, why the named one is not it)``: the folder vcavity's compiled code goes to in
    this process ("" for none), and, when the user named a folder (``NUMBA_CACHE_DIR``) that
    cannot be used, a one-line reason ("" otherwise)."""
    named = numba.config.CACHE_DIR
    refused = ""
    if named:
        reason = _unwritable_because(named)
        if reason is None:
            return os.path.abspath(named), ""
        refused = f"NUMBA_CACHE_DIR = {named!r}: cannot hold files ({reason})"
    # tried in turn, each made only when the one before cannot be used (no stray temporary folder)
    for candidate in (user_cache_dir, _private_temporary_cache):
        folder = candidate()
        if folder and _writable_folder(folder):
            folder = os.path.abspath(folder)
            if refused:
                print(f"vcavity: note: {refused}; compiled code goes to {folder} instead", file=sys.stderr)
            return folder, refused
    print(f"vcavity: note: {refused + '; ' if refused else ''}no writable Numba cache directory (set "
          "NUMBA_CACHE_DIR to one); kernels are compiled in every process", file=sys.stderr)
    return "", refused


#: Folder of vcavity's compiled code ("" when nothing can be cached), and why the folder the
#: user named with ``NUMBA_CACHE_DIR`` is not it ("" when none was named or it is used):
#: ``vcavity warmup`` refuses to fill another folder than the one named.
CACHE_LOCATION, NAMED_CACHE_REFUSED = _choose_cache()
#: Whether ``cache=True`` is honoured in this process.
CACHE_ENABLED = bool(CACHE_LOCATION)
# several processes may compile into this folder at once: their index writes made exclusive
cache_lock.install(CACHE_LOCATION)

_decorating = threading.Lock()  # the swap of numba.config.CACHE_DIR is process-wide


def _decorate(decorator, function):
    """``decorator(function)`` with Numba's cache folder set to :data:`CACHE_LOCATION`."""
    with _decorating:
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = CACHE_LOCATION
        try:
            return decorator(function)
        finally:
            numba.config.CACHE_DIR = saved


def cached(jit, function, **options):
    """``jit(function, cache=True, **options)`` caching in :data:`CACHE_LOCATION`: for the
    other targets' decorators that read ``numba.config.CACHE_DIR`` as Numba's does
    (numba-cuda's ``cuda.jit``, :mod:`vcavity.kernels.cuda_loop`). Call it only where
    :data:`CACHE_ENABLED`.

    Returns
    -------
    dispatcher
        What ``jit`` returns.
    """
    return _decorate(lambda f: jit(f, cache=True, **options), function)


def njit(*args, **options):
    """``numba.njit``, caching in :data:`CACHE_LOCATION` (or not at all where nothing can be cached).

    Parameters
    ----------
    *args, **options
        As for :func:`numba.njit`.

    Returns
    -------
    numba dispatcher or decorator
        What ``numba.njit`` returns.
    """
    if not options.get("cache"):
        return numba.njit(*args, **options)
    if not CACHE_ENABLED:
        return numba.njit(*args, **dict(options, cache=False))
    if len(args) == 1 and callable(args[0]):  # njit(function, cache=True)
        return _decorate(numba.njit(**options), args[0])
    decorator = numba.njit(*args, **options)
    return lambda function: _decorate(decorator, function)


__all__ = ["cached", "njit", "user_cache_dir", "CACHE_ENABLED", "CACHE_LOCATION"]
