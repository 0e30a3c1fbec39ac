"""One writer per output: a lock file beside a sweep file or a run's table and checkpoint.

Two commands writing one file at once each believe the file is theirs: the second sweep's
first point replaced the first sweep's file and both printed "wrote". A writer therefore
holds ``OUT.lock`` beside its output ``OUT`` from its checks to its exit, and a second
writer is refused, before it writes anything or traces a path, with the holder's pid and
host.

The lock file is created with ``O_CREAT | O_EXCL`` (atomic on local file systems, NFS v3
and later, Lustre and GPFS) and holds one line of JSON: ``pid``, ``host``, ``started``
(UTC), ``command`` and ``flock`` (whether the holder also holds ``flock`` on it). Where
the file system supports it the holder keeps an exclusive ``flock`` on the file as well:
an advisory lock the kernel drops when the process dies, which tells a live holder from a
dead one whose pid was reused, and, on NFS where ``flock`` is a network lock, a live
holder on another host.

A lock whose holder is gone is taken over: on the same host a holder is gone when its pid
no longer exists, or when it held ``flock`` and the lock can now be taken (its pid was
reused). A holder on another host cannot be probed (its pid means nothing here): such a
lock is refused, naming the host, the pid and how to remove the lock if the user knows it
is stale. A lock file without a holder written in it (its writer died between creating
and writing it, a microsecond window) is stale after :data:`UNNAMED_GRACE_S`.

The lock is released (the file removed) when the writer leaves the ``with`` block: on
success, on an error and on Ctrl-C or SIGTERM (both end as exceptions there); a
``kill -9`` leaves it behind, stale, and the next writer takes it over. Readers (``info``,
plots, exports, the table API) take no lock: files are replaced atomically.
"""

from __future__ import annotations

import errno
import json
import os
import shlex
import socket
import sys
import time
from pathlib import Path
from stat import S_ISREG

from vcavity.io.atomic import _pid_alive

try:
    import fcntl
except ImportError:  # not POSIX: the lock file alone
    fcntl = None

SUFFIX = ".lock"
UNNAMED_GRACE_S = 10.0  # a lock file still empty after this long was left by a writer killed while creating it


class LockError(ValueError):
    """The lock cannot be taken; the message is the rest of a one-line error (after the field)."""


def lock_path(output) -> Path:
    """The lock file of a writer of ``output``: ``<output>.lock`` beside it."""
    output = Path(os.fspath(output))
    return output.with_name(output.name + SUFFIX)


def _hold_flock(fd: int) -> bool | None:
    """Take ``flock(LOCK_EX | LOCK_NB)`` on ``fd``: True taken, False held by another, None
    not supported here (no ``fcntl``, or a file system without it, e.g. Lustre without ``-o flock``)."""
    if fcntl is None:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            return False
        return None
    return True


class WriterLock:
    """Context manager: hold the lock of ``output`` (module doc) while in the ``with`` block.

    Parameters
    ----------
    output : str or os.PathLike
        The file this process is about to write (a sweep file, or a run's table: its
        checkpoint ``OUT.checkpoint`` is covered by the same lock).

    Attributes
    ----------
    path : pathlib.Path
        The lock file, ``<output>.lock``.
    took_over : dict or None
        The holder of a stale lock this writer took over (its JSON fields), else None.

    Raises
    ------
    LockError
        On entering: another writer holds the lock, or the folder cannot hold it (one line).
    """

    def __init__(self, output):
        self.path = lock_path(output)
        self.took_over = None
        self._fd = None
        self._identity = None

    def __enter__(self) -> "WriterLock":
        for _ in range(100):  # each turn takes the lock, refuses, or (tries to) remove a stale one
            if self._create():
                return self
            self._probe_existing()  # raises while the holder lives; removes a stale lock
        raise LockError(f"the lock file {str(self.path)!r} keeps coming back; another writer is starting "
                        "on this output")

    def __exit__(self, *exc_info) -> bool:
        self.release()
        return False

    def _create(self) -> bool:
        """Create the lock file with our holder in it: True done, False one exists."""
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o644)
        except FileExistsError:
            return False
        except OSError as exc:
            raise LockError(f"cannot create a file in folder {str(self.path.parent)!r} ({exc.strerror or exc}): "
                            f"the lock file {self.path.name!r} that keeps a second writer out cannot be made "
                            "there") from None
        try:
            flocked = _hold_flock(fd)
            holder = {"pid": os.getpid(), "host": socket.gethostname(),
                      "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
                      "command": _command(),
                      "flock": bool(flocked)}
            os.write(fd, (json.dumps(holder) + "\n").encode())
            os.fsync(fd)
        except BaseException as exc:
            os.close(fd)
            self.path.unlink(missing_ok=True)
            if isinstance(exc, OSError):
                raise LockError(f"cannot write the lock file {str(self.path)!r} ({exc.strerror or exc})") from None
            raise
        self._fd = fd
        stat = os.fstat(fd)
        self._identity = (stat.st_dev, stat.st_ino)
        return True

    def _probe_existing(self) -> None:
        """Refuse a live holder's lock (:class:`LockError`); remove a stale one."""
        try:
            fd = os.open(self.path, os.O_RDWR | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0))
        except FileNotFoundError:
            return  # released meanwhile: try again
        except OSError as exc:
            try:
                fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0))
            except FileNotFoundError:
                return
            except OSError:
                raise LockError(f"{str(self.path)!r} exists and is not a lock file vcavity can read "
                                f"({exc.strerror or exc}); move it away if no vcavity writes this output") from None
        try:
            stat = os.fstat(fd)
            if not S_ISREG(stat.st_mode):
                raise LockError(f"{str(self.path)!r} exists and is not a lock file (not a regular file); move it "
                                "away: the writer of this output puts its lock file there")
            content = os.read(fd, 1 << 16)
            free = _hold_flock(fd)  # a flock taken here is dropped by os.close below
        finally:
            os.close(fd)
        holder = _parse(content)
        if self._alive(holder, free, time.time() - stat.st_mtime):
            raise LockError(_refusal(self.path, holder, live=free is False))
        self._remove_stale((stat.st_dev, stat.st_ino, stat.st_mtime_ns, content))
        self.took_over = holder or {}

    @staticmethod
    def _alive(holder: dict | None, free: bool | None, age_s: float) -> bool:
        """Whether the lock's holder may still be writing (``free``: our flock probe's answer)."""
        if free is False:
            return True  # someone holds flock on it: a live process
        if holder is None:
            return age_s < UNNAMED_GRACE_S  # being created just now, or left by a writer killed creating it
        if holder["host"] != socket.gethostname():
            return True  # cannot be probed from here (the refusal says so)
        if free and holder.get("flock"):
            return False  # it held flock, nobody does now: its process is gone (its pid may be reused)
        return holder["pid"] == os.getpid() or _pid_alive(holder["pid"])

    def _remove_stale(self, seen) -> None:
        """Remove the stale lock file as it was ``seen`` (device, inode, mtime, content), never
        a fresh one: only one writer at a time removes (it holds ``<lock>.break``, created
        with ``O_EXCL``), and only a file still exactly as seen (an inode number can be
        reused at once by the next writer's lock, its pid and mtime cannot)."""
        breaker = self.path.with_name(self.path.name + ".break")
        try:
            os.close(os.open(breaker, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
        except FileExistsError:  # another writer is removing it: let it, unless it died doing so
            try:
                if time.time() - os.stat(breaker).st_mtime > UNNAMED_GRACE_S:
                    os.unlink(breaker)
            except OSError:
                pass
            time.sleep(0.05)
            return
        except OSError as exc:
            raise LockError(f"cannot remove the stale lock file {str(self.path)!r} ({exc.strerror or exc})") from None
        try:
            if _look(self.path) == seen:
                os.unlink(self.path)
        except OSError:
            pass  # gone or changed meanwhile: the next turn looks again
        finally:
            breaker.unlink(missing_ok=True)

    def note(self) -> str | None:
        """What to tell the user of the stale lock this writer took over, or None."""
        if self.took_over is None:
            return None
        if not self.took_over:
            return f"took over the lock file {str(self.path)!r}, left without a holder by a writer killed creating it"
        since = f", since {self.took_over['started']}" if self.took_over.get("started") else ""
        return (f"took over the stale lock file {str(self.path)!r} of pid {self.took_over['pid']} on host "
                f"{self.took_over['host']}{since}: that process is gone")

    def release(self) -> None:
        """Remove the lock file if it is still ours, then drop the flock (idempotent)."""
        if self._fd is None:
            return
        try:
            stat = os.lstat(self.path)
            if (stat.st_dev, stat.st_ino) == self._identity:
                os.unlink(self.path)
        except OSError:
            pass  # removed by hand, or the folder went away: nothing of ours is left there
        finally:
            os.close(self._fd)
            self._fd = None


def _look(path: Path):
    """``(device, inode, mtime, content)`` of the lock file at ``path`` (links not followed)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0))
    try:
        stat = os.fstat(fd)
        return stat.st_dev, stat.st_ino, stat.st_mtime_ns, os.read(fd, 1 << 16)
    finally:
        os.close(fd)


def _command() -> str:
    """This process's command line as a shell would show it (``python -m vcavity``: ``vcavity``)."""
    if not sys.argv:
        return ""
    name = Path(sys.argv[0]).name
    return shlex.join(["vcavity" if name == "__main__.py" else name] + sys.argv[1:])


def _parse(content: bytes) -> dict | None:
    """The holder written in a lock file, or None when there is none (empty, not ours)."""
    try:
        holder = json.loads(content.decode())
        if isinstance(holder, dict) and isinstance(holder.get("pid"), int) and isinstance(holder.get("host"), str):
            return holder
    except (UnicodeDecodeError, ValueError):
        pass
    return None


def _refusal(path: Path, holder: dict | None, live: bool = False) -> str:
    """The one-line refusal of a lock held (or possibly held) by ``holder``; ``live``: its
    flock is held, so its holder runs, wherever it is."""
    if holder is None:
        return (f"another writer is creating its lock file {str(path)!r} (no holder written in it yet); "
                "try again in a few seconds")
    who = f"pid {holder['pid']} on host {holder['host']}"
    since = f", since {holder['started']}" if holder.get("started") else ""
    command = f", {holder['command']!r}" if holder.get("command") else ""
    if live or holder["host"] == socket.gethostname():
        return (f"is being written by another vcavity ({who}{since}{command}); wait for it to finish or give "
                f"another output (lock file {str(path)!r})")
    return (f"is locked by a vcavity on another host ({who}{since}{command}), which cannot be checked from "
            f"host {socket.gethostname()}; if that process is gone, remove the lock file {str(path)!r} and "
            "run again")


__all__ = ["LockError", "SUFFIX", "UNNAMED_GRACE_S", "WriterLock", "lock_path"]
