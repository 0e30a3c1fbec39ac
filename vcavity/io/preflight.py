"""Checks that run before the first path is traced: output path, disk space, memory.

Everything here can fail on the user's input or machine, so it runs before compiling or
tracing: a bad output path, a full disk or a run that cannot fit in memory is
a one-line :class:`PreflightError` naming the field as the user wrote it (``--output``,
``output.path``, ``simulation.sensor_resolution``), the value and what is accepted,
instead of a traceback after hours of work. Plain Python and NumPy: no Numba, no h5py.
"""

from __future__ import annotations

import os
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path

from vcavity.io import atomic, lock

_MB = 1024.0**2
_TABLE_OVERHEAD_BYTES = 1 << 20  # HDF5 metadata, attributes, the config JSON: well under 1 MB


class PreflightError(ValueError):
    """A run cannot start or could not finish; the message is one line (field, value, what is accepted)."""


@dataclass(frozen=True)
class Output:
    """Where a run writes its table, and how the user named it (for messages)."""

    path: Path
    field: str  # "--output", "output.path", or "output" (a default) as the user knows it
    shown: str  # the value as written

    def fail(self, accepted: str) -> PreflightError:
        """A one-line error about this output: ``field = 'value': accepted``."""
        return PreflightError(f"{self.field} = {self.shown!r}: {accepted}")


def resolve_output(option: str | None, configured: Path | None, config_file: str | None) -> Output:
    """The table path of a run: ``-o``, else ``[output].path``, else CONFIG with .h5, else the default.

    Raises
    ------
    PreflightError
        ``-o ""`` or ``-o DIR/`` (a folder, not a file), or no ``-o`` with a config read
        from a pipe or special file (``<(cat c.toml)``, ``/dev/stdin``).
    """
    if option is None and config_file:
        try:
            mode = os.stat(config_file).st_mode
        except OSError:
            mode = stat.S_IFREG  # read a moment ago; if it is gone, the derived name still stands
        if not stat.S_ISREG(mode):
            # /dev/fd/63.h5 or a path relative to /dev/fd: no file name to build on
            raise PreflightError(f"config file {config_file!r}: is {_kind(mode)}, not a regular file, so the "
                                 "output cannot be named after it (nor beside it); give the output with -o OUT.h5")
    if option is not None:
        if option == "":
            raise PreflightError("--output = '': must be a file path such as 'table.h5'")
        if option.endswith(("/", os.sep)) or Path(option).name in ("", ".", ".."):
            raise PreflightError(f"--output = {option!r}: names a folder (trailing '/'); "
                                 f"give a file path such as {os.path.join(option, 'table.h5')!r}")
        return Output(Path(option), "--output", option)
    if configured is not None:
        return Output(Path(configured), "output.path", str(configured))
    if config_file:
        derived = Path(config_file).with_suffix(".h5")
        return Output(derived, "output (default: the config's name with .h5)", str(derived))
    return Output(Path("vcavity-default.h5"), "output (default)", "vcavity-default.h5")


def _size(n_bytes: float) -> str:
    """Bytes for a message: GB from 1 GB on, else MB (3 significant digits)."""
    return f"{n_bytes / 1024**3:,.2f} GB" if n_bytes >= 1024**3 else f"{n_bytes / _MB:.3g} MB"


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def check_output(out: Output, config_file: str | None, overwrite: bool, source: str | None = None) -> None:
    """Refuse an output the atomic rename must not replace, or cannot create.

    An existing link, folder, FIFO or device is never replaced (the rename would replace
    the node itself); the run config or the command's input file (``source``: the table
    ``export`` or ``plot`` reads) is never the output, whatever path names it (same file,
    compared with ``os.path.samefile``); an existing file only with ``--overwrite``.
    ``run``, ``sweep``, ``export`` and ``plot`` all check their output here.

    Raises
    ------
    PreflightError
        One line naming ``out.field``.
    """
    path = out.path
    if out.shown == "-":  # what many tools read as standard output: never a file named '-' by surprise
        raise out.fail("is not standard output here: vcavity writes files only; give a file name "
                       "(./- for a file named '-')")
    try:
        info = path.lstat()
    except FileNotFoundError:
        info = None
    except NotADirectoryError:
        info = None  # a parent is a file: reported below
    except OSError as exc:
        raise out.fail(f"cannot inspect it ({exc.strerror or exc})") from None
    if info is not None:
        if stat.S_ISLNK(info.st_mode):
            raise out.fail(f"is a symbolic link (to {os.readlink(path)!r}); the output is written by "
                           "an atomic rename, which would replace the link itself: give the target's path")
        if stat.S_ISDIR(info.st_mode):
            raise out.fail("is a directory; give a file path such as "
                           f"{os.path.join(out.shown, 'table.h5')!r}")
        if not stat.S_ISREG(info.st_mode):
            raise out.fail(f"exists and is {_kind(info.st_mode)}; only a regular file is replaced")
        if config_file is not None and os.path.samefile(path, config_file):
            raise out.fail(f"is the run config {config_file!r} itself; give the table another name "
                           "(-o OUT.h5)")
        if source is not None and os.path.exists(source) and os.path.samefile(path, source):
            raise out.fail(f"is the input {source!r} itself; give the output another name")
        if not overwrite:
            raise out.fail("exists; pass --overwrite to replace it (atomically, once the new file is complete)")
    _check_folder(out)


def _check_folder(out: Output) -> None:
    folder = out.path.parent
    if folder.is_dir():
        return
    ancestor = folder
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if ancestor.exists() and not ancestor.is_dir():
        raise out.fail(f"{str(ancestor)!r} is a file, not a folder")
    raise out.fail(f"folder {str(folder)!r} does not exist")


def probe_output(out: Output) -> list[Path]:
    """Remove stale temporary files of ``out``, then create and remove a new one.

    Returns
    -------
    list of pathlib.Path
        Stale temporary files removed (:func:`vcavity.io.atomic.remove_stale_temporaries`).

    Raises
    ------
    PreflightError
        The folder does not accept new files (read-only, ``/proc``, ``/sys``, permission).
    """
    removed = atomic.remove_stale_temporaries(out.path)
    try:
        atomic.probe_destination(out.path)
    except OSError as exc:
        raise out.fail(f"cannot create a file in folder {str(out.path.parent)!r} "
                       f"({exc.strerror or exc})") from None
    return removed


def lock_output(out: Output, locks) -> lock.WriterLock:
    """Hold the writer lock of ``out`` (:mod:`vcavity.io.lock`) until ``locks`` closes.

    Parameters
    ----------
    out : Output
    locks : contextlib.ExitStack
        Releases the lock when it closes (the command's end: success, error or Ctrl-C).

    Returns
    -------
    vcavity.io.lock.WriterLock
        The lock held (its ``took_over`` names a stale holder it replaced).

    Raises
    ------
    PreflightError
        Another writer holds it, or the folder cannot hold it (one line naming ``out.field``).
    """
    try:
        return locks.enter_context(lock.WriterLock(out.path))
    except lock.LockError as exc:
        raise out.fail(str(exc)) from None


def table_bytes(n_incidence: int, n_orders: int, n_cells: int) -> int:
    """Upper bound of a table's size: ``counts``, ``brdf``, ``brdf_stderr`` uncompressed.

    Three 8-byte (incidence, order, cell) arrays (docs/hdf5-format.md) plus the per-cell
    geometry; gzip usually shrinks them several times, never grows them noticeably.
    """
    return 8 * (3 * n_incidence * n_orders * n_cells + 8 * n_cells) + _TABLE_OVERHEAD_BYTES


def check_disk_space(out: Output, needed: int) -> None:
    """Refuse a run whose table cannot fit on the output's file system.

    The old table stays until the rename, so the whole new table must fit beside it.

    Raises
    ------
    PreflightError
    """
    try:
        free = shutil.disk_usage(out.path.parent).free
    except OSError:
        return  # cannot tell (some network file systems): the write reports a full disk itself
    if needed > free:
        raise out.fail(f"the table needs up to {_size(needed)} (uncompressed bound), "
                       f"only {_size(free)} free in {str(out.path.parent)!r}; free space "
                       "or lower sensor_resolution, max_order or the number of directions")


def run_memory_bytes(n_incidence: int, n_orders: int, max_order: int, n_cells: int, threads: int,
                     tallies: int = 1) -> int:
    """Peak memory of a run, bytes (8-byte integers and floats).

    While tracing: per thread slot and the running sum, ``tallies`` (1; paper: 3) arrays
    of (max_order + 1, cells) (kernels/trace.py), plus the result's ``counts``, ``brdf``,
    ``brdf_stderr`` (incidence, order, cell). While writing: those three plus about eight
    more of that shape (writer.py: float copies, the stderr expression's temporaries), and
    the table's HDF5 image twice: the ``core`` driver's file in memory and the bytes copy
    that is written out (io/atomic.py ``write_hdf5``), each at most :func:`table_bytes`.
    """
    per_table_array = 8 * n_incidence * n_orders * n_cells
    tracing = 8 * tallies * (threads + 2) * (max_order + 1) * n_cells + 3 * per_table_array
    writing = 11 * per_table_array + 2 * table_bytes(n_incidence, n_orders, n_cells)
    return max(tracing, writing)


def available_memory() -> int | None:
    """Bytes this process can still allocate without swapping, or None when unknown.

    ``MemAvailable`` of /proc/meminfo, lowered by a cgroup (container) limit if one is set.
    """
    available = None
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            available = None
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = int(Path("/sys/fs/cgroup/memory.current").read_text())
        if limit != "max":
            room = int(limit) - used
            available = room if available is None else min(available, room)
    except (OSError, ValueError):
        pass
    return available


def check_memory(config, threads: int, n_cells: int, tallies: int = 1) -> int:
    """Refuse a run whose arrays cannot fit in memory; return the estimate (bytes).

    Parameters
    ----------
    config : vcavity.config.RunConfig
    threads : int
        Threads the run uses (one tally per kernel slot, a slot per thread). On
        ``config.device = "cuda"`` not counted: the host gets one tally set per kernel call
        (the GPU's own memory is checked where the device is, vcavity.simulate.plan).
    n_cells : int
        Sensor cells (``sensor_resolution`` squared).
    tallies : int
        Tally planes per slot (the estimator's: analog 1, paper 3).

    Raises
    ------
    PreflightError
        Naming ``simulation.sensor_resolution`` and ``max_order``, with the figure.
    """
    gpu = getattr(config, "device", "cpu") == "cuda"
    needed = run_memory_bytes(len(config.incidence), len(config.orders), config.max_order, n_cells,
                              1 if gpu else threads, tallies)
    available = available_memory()
    if available is not None and needed > available:
        slots = "the GPU's tally" if gpu else f"{threads} thread(s)"
        raise PreflightError(
            f"simulation.sensor_resolution = {config.sensor_resolution} with max_order = "
            f"{config.max_order}: the run needs about {_size(needed)} of memory "
            f"({slots} x {config.max_order + 1} orders x {n_cells:,} cells per tally, "
            f"{len(config.incidence)} direction(s)), {_size(available)} available; "
            f"accepted: a run that fits (lower sensor_resolution, max_order{'' if gpu else ' or --threads'})")
    return needed


def check_plots_folder(text: str) -> Path:
    """``compare --plots DIR``: refuse a file, a path under a file, or an unwritable folder.

    Raises
    ------
    PreflightError
        Naming ``--plots``, before anything is computed.
    """
    if text == "":
        raise PreflightError("--plots = '': must be a folder path")
    folder = Path(text)
    ancestor = folder
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        where = "is a file" if ancestor == folder else f"is under {str(ancestor)!r}, a file"
        raise PreflightError(f"--plots = {text!r}: {where}, not a folder; give a folder for the PNGs")
    try:  # really create a file there: access() says yes to root even in /proc
        atomic.probe_destination(ancestor / "plot.png")
    except OSError as exc:
        raise PreflightError(f"--plots = {text!r}: cannot create files in {str(ancestor)!r} "
                             f"({exc.strerror or exc})") from None
    return folder


__all__ = ["Output", "PreflightError", "available_memory", "check_disk_space", "check_memory",
           "check_output", "check_plots_folder", "probe_output", "resolve_output", "run_memory_bytes",
           "table_bytes"]
