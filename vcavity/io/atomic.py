"""Atomic file replacement and the temporary files it uses (tables, sweeps, checkpoints, plots).

A file is written to a hidden temporary file in its destination folder, flushed, fsynced
and renamed onto the destination (``os.replace`` is atomic within one file system), so a
reader sees the old file or the complete new one, never a partial file; on any failure
(disk full, Ctrl-C) the temporary file is removed and the old file is untouched.

Temporary files are named ``.NAME.<pid>-<host>.<random>.tmp`` beside ``NAME``: the pid
and a tag of the host let a later run tell a leftover of a killed writer (kill -9, power
loss) from the file of a writer still running, and remove only the former.

HDF5 files (tables, sweep files, checkpoints) go through :func:`write_hdf5`: h5py builds
the whole file in memory and plain file I/O writes its bytes. HDF5 writing to a disk that
fills up reported "Can't close dataset" tracebacks, left open handles behind and could
crash the interpreter at exit (SIGSEGV); a full disk here is an ordinary ``OSError``
raised by :func:`write_bytes`, with the temporary file removed.
"""

from __future__ import annotations

import hashlib
import os
import re
import secrets
import socket
import time
from pathlib import Path
from typing import Callable

STALE_AGE_S = 3600.0  # no table write takes an hour: older files of unknown writers are stale
_HOST_TAG = hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def _temporary_pattern(name: str) -> re.Pattern:
    """Our temporary names for destination ``name``: pid-tagged, and the older untagged form."""
    return re.compile(rf"\.{re.escape(name)}\.(?:(?P<pid>\d+)-(?P<host>[0-9a-f]{{8}})\.)?[0-9a-f]{{12}}\.tmp")


def create_temporary(destination: Path) -> Path:
    """Create an empty hidden temporary file beside ``destination`` (mode 0666 minus the umask).

    Raises
    ------
    OSError
        The folder does not accept new files.
    """
    destination = Path(os.fspath(destination))
    while True:
        candidate = destination.with_name(
            f".{destination.name}.{os.getpid()}-{_HOST_TAG}.{secrets.token_hex(6)}.tmp")
        try:
            os.close(os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return candidate


def probe_destination(path) -> None:
    """Check that a file can be created beside ``path``: create a temporary file and remove it.

    Raises
    ------
    OSError
        The folder does not accept new files (read-only, ``/proc``, ``/sys``, no permission).
    """
    create_temporary(Path(os.fspath(path))).unlink()


def replace_atomically(path, fill: Callable[[Path], None],
                       cancelled: Callable[[], bool] | None = None) -> None:
    """Write ``path`` atomically: ``fill(temporary)``, fsync, rename onto ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The destination; an existing file there is replaced only on success.
    fill : callable
        Writes the complete content into the (empty) temporary file it is given.
    cancelled : callable, optional
        Asked once the temporary file is complete and synced, just before the rename:
        True (Ctrl-C was pressed meanwhile) removes it and raises ``KeyboardInterrupt``.

    Raises
    ------
    KeyboardInterrupt
        ``cancelled()`` returned True; ``path`` is untouched.
    OSError
        Writing failed (disk full, ...); ``path`` is untouched, no temporary file is left.
    """
    destination = Path(os.fspath(path))
    temporary = create_temporary(destination)
    try:
        fill(temporary)
        _fsync(temporary)
        if cancelled is not None and cancelled():
            raise KeyboardInterrupt("write cancelled before the rename")
        os.replace(temporary, destination)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    try:
        _fsync(destination.parent)  # make the rename durable; not possible everywhere
    except OSError:
        pass


def write_bytes(temporary: Path, data: bytes) -> None:
    """Write ``data`` into the file ``temporary`` (plain file I/O: a full disk is an ``OSError``)."""
    with open(temporary, "wb") as stream:
        stream.write(data)


def write_hdf5(path, build: Callable, cancelled: Callable[[], bool] | None = None, **options) -> None:
    """Write an HDF5 file atomically: ``build(h5)`` in memory, then its bytes to ``path``.

    The file is built with h5py's ``core`` driver (``backing_store=False``: nothing touches
    the disk), its image written by :func:`write_bytes` into a temporary file beside
    ``path``, fsynced and renamed (:func:`replace_atomically`).

    Parameters
    ----------
    path : str or os.PathLike
        The destination; an existing file there is replaced only on success.
    build : callable
        ``build(h5)`` fills the open, empty ``h5py.File``.
    cancelled : callable, optional
        As in :func:`replace_atomically`: asked just before the rename.
    **options
        Further ``h5py.File`` arguments (``track_order=True``).

    Raises
    ------
    KeyboardInterrupt
        ``cancelled()`` returned True; ``path`` is untouched.
    OSError
        Writing failed (disk full, ...); ``path`` is untouched, no temporary file is left.
    """
    import h5py  # here, not at the top: preflight imports this module and must not load h5py

    # the name only identifies the in-memory file; unique, so no two can collide in HDF5
    name = f"vcavity-image-{os.getpid()}-{secrets.token_hex(8)}.h5"
    with h5py.File(name, "w", driver="core", backing_store=False, **options) as h5:
        build(h5)
        h5.flush()
        image = h5.id.get_file_image()
    replace_atomically(path, lambda temporary: write_bytes(temporary, image), cancelled=cancelled)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # exists under another user (or not a pid we can ask about): keep its file
    return True


def remove_stale_temporaries(path, now: float | None = None) -> list[Path]:
    """Remove temporary files that interrupted writes of ``path`` left behind.

    A temporary file of ours (see the module doc) is stale when the process that wrote it
    on this host no longer exists, or, when that cannot be told (another host, or the
    untagged names of earlier versions), when it is older than :data:`STALE_AGE_S`.
    Files of running writers, directories, links and every other file are left alone.

    Parameters
    ----------
    path : str or os.PathLike
        The destination whose leftovers to remove.
    now : float, optional
        The current time (``time.time()``), for tests.

    Returns
    -------
    list of pathlib.Path
        The files removed.
    """
    destination = Path(os.fspath(path))
    pattern = _temporary_pattern(destination.name)
    now = time.time() if now is None else now
    removed = []
    try:
        entries = list(os.scandir(destination.parent))
    except OSError:
        return removed
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if match is None:
            continue
        try:
            if not entry.is_file(follow_symlinks=False):
                continue
            pid, host = match.group("pid"), match.group("host")
            if pid is not None and host == _HOST_TAG:
                stale = int(pid) != os.getpid() and not _pid_alive(int(pid))
            else:
                stale = now - entry.stat(follow_symlinks=False).st_mtime > STALE_AGE_S
            if stale:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue  # vanished meanwhile, or not ours to remove: leave it
    return removed


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


__all__ = ["STALE_AGE_S", "create_temporary", "probe_destination", "remove_stale_temporaries",
           "replace_atomically", "write_bytes", "write_hdf5"]
