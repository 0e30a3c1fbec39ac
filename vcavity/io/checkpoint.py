"""The checkpoint file of an unfinished run (atomic, checksummed).

A checkpoint is an HDF5 file (``format = "vcavity-checkpoint"``) holding a run's state as
named integer and boolean arrays (:class:`vcavity.simulate.state.RunState` says what they
are), the run's full configuration as JSON and a SHA-256 digest of both: a truncated or
corrupted file, or one of another configuration, is detected and refused, never silently
restarted. It is written like a table: temporary file in the same folder, flush, fsync,
rename. This module only serialises; the state is the run's.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Mapping

import numpy as np

FORMAT_NAME = "vcavity-checkpoint"
FORMAT_VERSION = 1
_ARRAYS = ("done_blocks", "finished", "reached", "tally", "stats")


class CheckpointError(ValueError):
    """A checkpoint cannot be used (unreadable, corrupted, or of another run); one line."""


def checkpoint_path(output: Path) -> Path:
    """Where the checkpoint of a run writing ``output`` lives: ``<output>.checkpoint``."""
    output = Path(output)
    return output.with_name(output.name + ".checkpoint")


def config_digest(config_dict: dict) -> str:
    """SHA-256 of the run-defining configuration (the output path excluded)."""
    defining = {key: value for key, value in config_dict.items() if key not in ("output", "source")}
    return hashlib.sha256(json.dumps(defining, sort_keys=True, default=str).encode()).hexdigest()


def _payload_digest(arrays: Mapping[str, np.ndarray], config_json: str) -> str:
    digest = hashlib.sha256(config_json.encode())
    for name in _ARRAYS:
        array = np.ascontiguousarray(arrays[name])
        digest.update(name.encode() + str(array.dtype).encode() + str(array.shape).encode())
        digest.update(array.tobytes())
    return digest.hexdigest()


def save(path, arrays: Mapping[str, np.ndarray], compute_time_s: float, config_dict: dict, paths_done: int,
         paths_planned: int) -> None:
    """Write a run's state atomically to ``path`` (:func:`vcavity.io.atomic.write_hdf5`: built
    in memory, temporary file, fsync, ``os.replace``; names and cleanup those of tables).

    ``arrays`` holds ``done_blocks``, ``finished``, ``reached``, ``tally`` and ``stats``
    (booleans are stored as int8); ``paths_done`` and ``paths_planned`` are for ``vcavity info``.

    Raises
    ------
    OSError
        The file could not be written (disk full, ...); a checkpoint already at ``path`` is
        unchanged and no temporary file is left.
    """
    from vcavity.io.atomic import remove_stale_temporaries, write_hdf5

    config_json = json.dumps(config_dict, sort_keys=True, default=str)

    def build(h5):
        h5.attrs.update({"format": FORMAT_NAME, "format_version": np.int64(FORMAT_VERSION),
                         "config": config_json, "config_digest": config_digest(config_dict),
                         "payload_sha256": _payload_digest(arrays, config_json),
                         "compute_time_s": float(compute_time_s),
                         "paths_done": np.int64(paths_done), "paths_planned": np.int64(paths_planned)})
        for name in _ARRAYS:
            array = np.asarray(arrays[name])
            h5.create_dataset(name, data=array.astype(np.int8) if array.dtype == bool else array)

    remove_stale_temporaries(path)
    write_hdf5(Path(path), build)


def refuse_non_file(path) -> None:
    """Refuse a checkpoint path holding something that is not a regular file.

    A folder (or FIFO, device) at ``OUT.h5.checkpoint`` is no checkpoint to resume, and the
    run could not save its progress there either; said before anything is compiled.

    Raises
    ------
    CheckpointError
    """
    import stat

    try:
        mode = Path(path).lstat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        return
    if stat.S_ISREG(mode):
        return
    kind = ("a folder" if stat.S_ISDIR(mode) else "a symbolic link" if stat.S_ISLNK(mode)
            else "a FIFO" if stat.S_ISFIFO(mode) else "not a regular file")
    raise CheckpointError(f"checkpoint {str(path)!r} is {kind}, not a checkpoint: the run saves its progress "
                          "there; move it away or write the table elsewhere")


def load(path, config_dict: dict) -> tuple[dict, float]:
    """Read and verify a checkpoint of the run ``config_dict``: its arrays and compute time.

    Returns
    -------
    arrays : dict of str to ndarray
        ``done_blocks``, ``finished``, ``reached`` (int8 0/1), ``tally``, ``stats``.
    compute_time_s : float

    Raises
    ------
    CheckpointError
        Missing, unreadable, truncated or corrupted file (digest mismatch), or a
        checkpoint of another configuration or seed.
    """
    import h5py

    path = Path(path)
    refuse_non_file(path)
    if not path.is_file():
        raise CheckpointError(f"--resume: no checkpoint {str(path)!r} to resume from")
    try:
        with h5py.File(path, "r") as h5:
            attrs = dict(h5.attrs)
            arrays = {name: h5[name][()] for name in _ARRAYS}
    except (OSError, KeyError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise CheckpointError(f"checkpoint {str(path)!r} is unreadable or truncated ({first}); "
                              "it was left as it is") from None
    if attrs.get("format") != FORMAT_NAME or int(attrs.get("format_version", -1)) != FORMAT_VERSION:
        raise CheckpointError(f"{str(path)!r} is not a vcavity checkpoint of format {FORMAT_VERSION}")
    stored_json = str(attrs.get("config", ""))
    if _payload_digest({name: _as_stored(array) for name, array in arrays.items()}, stored_json) \
            != attrs.get("payload_sha256"):
        raise CheckpointError(f"checkpoint {str(path)!r} is corrupted (its SHA-256 digest does not match); "
                              "it was left as it is")
    if attrs.get("config_digest") != config_digest(config_dict):
        raise CheckpointError(f"checkpoint {str(path)!r} belongs to another run (its config or seed differs); "
                              "resume with the same config and --seed, or start afresh with --overwrite")
    return arrays, float(attrs.get("compute_time_s", 0.0))


def _as_stored(array: np.ndarray) -> np.ndarray:
    """An array as it was digested when saved: booleans (stored as int8) as booleans."""
    return array.astype(bool) if array.dtype == np.int8 else array.astype(np.int64)


def foreign_output(path, config_dict: dict) -> str | None:
    """What the regular file ``path`` is, unless it is a table of the run ``config_dict``.

    ``--resume`` may replace the table its own run wrote (same configuration and seed:
    the table was renamed into place, the checkpoint not yet removed), nothing else.

    Returns
    -------
    str or None
        None for a table of this run; else what the file is, for a one-line refusal
        (``"a sweep file"``, ``"a table of another run (...)"``, ``"not a vcavity table"``).
    """
    import h5py

    from vcavity.io import schema

    try:
        with h5py.File(path, "r") as h5:
            kind, stored = h5.attrs.get("format"), h5.attrs.get("config")
    except OSError:
        return "not a vcavity table"
    kind = kind.decode() if isinstance(kind, bytes) else kind
    if kind == schema.FORMAT_NAME:
        try:
            same = config_digest(json.loads(str(stored))) == config_digest(config_dict)
        except (TypeError, ValueError, AttributeError):
            same = False
        return None if same else "a table of another run (its config or seed differs)"
    return {"vcavity-sweep": "a sweep file", FORMAT_NAME: "a checkpoint"}.get(kind, "not a vcavity table")


def describe(path) -> dict:
    """Summary of a checkpoint for ``vcavity info``: paths done and planned, config."""
    import h5py

    with h5py.File(path, "r") as h5:
        return {"paths_done": int(h5.attrs["paths_done"]), "paths_planned": int(h5.attrs["paths_planned"]),
                "config": json.loads(str(h5.attrs["config"])),
                "compute_time_s": float(h5.attrs.get("compute_time_s", 0.0))}


def is_checkpoint(path) -> bool:
    """Whether ``path`` is an HDF5 file with ``format = "vcavity-checkpoint"``."""
    import h5py

    try:
        with h5py.File(path, "r") as h5:
            return h5.attrs.get("format") == FORMAT_NAME
    except OSError:
        return False
