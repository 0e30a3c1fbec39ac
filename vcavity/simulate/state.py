"""The state of an unfinished run, and its checkpoint (what :mod:`vcavity.io.checkpoint` stores).

A :class:`RunState` holds, per incident direction, the integer tally of the blocks traced
so far (blocks ``0 .. done_blocks - 1``, always a prefix, so a resumed run traces exactly
the blocks an uninterrupted one would), the estimator's statistics columns and whether
the direction is finished. Integer sums merge exactly, so resuming gives a bitwise
identical table. The checkpoint file (atomic, checksummed, refused when it is another
run's) is io's; this module gives it the state's arrays and rebuilds the state from them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vcavity.estimators import registry as estimators
from vcavity.io import checkpoint
from vcavity.rng import BLOCK_SIZE

#: The arrays of a state, as the checkpoint stores them.
ARRAYS = ("done_blocks", "finished", "reached", "tally", "stats")


@dataclass
class RunState:
    """Progress of a run (see module doc); arrays are updated in place while it runs.

    Attributes
    ----------
    done_blocks : ndarray of int64 (incidence,)
        Blocks traced per direction (a prefix of its blocks).
    finished, reached : ndarray of bool (incidence,)
        Direction done; target error reached.
    tally : ndarray of int64 (incidence, planes, max_order + 1, cells)
        The estimator's tally planes (``TALLIES``), order slot 0 beyond max_order.
    stats : ndarray of int64 (incidence, columns)
        The estimator's statistics columns (``STATS``).
    compute_time_s : float
        Seconds spent tracing so far.
    """

    done_blocks: np.ndarray
    finished: np.ndarray
    reached: np.ndarray
    tally: np.ndarray
    stats: np.ndarray
    compute_time_s: float = 0.0

    def paths_done(self, config) -> np.ndarray:
        """Paths traced so far per direction of ``config`` (its budgets cap the last block)."""
        budgets = np.array([config.path_budget(d) for d in config.incidence], np.int64)
        return np.minimum(self.done_blocks * BLOCK_SIZE, budgets)


def start(config, n_cells: int) -> RunState:
    """The state of the run ``config`` before its first path: per direction its estimator's
    tally planes and statistics columns, all 0 (an estimator without a walk: every
    direction finished)."""
    estimator = estimators.get(config.estimator)
    n_inc = len(config.incidence)
    return RunState(done_blocks=np.zeros(n_inc, np.int64),
                    finished=np.full(n_inc, estimator.walk(config.material) is None),
                    reached=np.zeros(n_inc, bool),
                    tally=np.zeros((n_inc, len(estimator.TALLIES), config.max_order + 1, n_cells), np.int64),
                    stats=np.zeros((n_inc, len(estimator.STATS)), np.int64), compute_time_s=0.0)


def save(path, state: RunState, config, paths_planned: int) -> None:
    """Write ``state`` of the run ``config`` atomically to ``path``
    (:func:`vcavity.io.checkpoint.save`; ``paths_planned`` for ``vcavity info``).

    Raises
    ------
    OSError
        The file could not be written; a checkpoint already at ``path`` is unchanged.
    """
    checkpoint.save(path, {name: getattr(state, name) for name in ARRAYS}, state.compute_time_s,
                    config.to_dict(), int(state.paths_done(config).sum()), paths_planned)


def load(path, config, layout: RunState | None = None) -> RunState:
    """The state a checkpoint of the run ``config`` holds.

    Parameters
    ----------
    layout : RunState, optional
        A state of the run as it starts (its arrays' shapes): a checkpoint whose arrays have
        other shapes (of another estimator layout) is refused.

    Raises
    ------
    vcavity.io.checkpoint.CheckpointError
        Missing, unreadable, corrupted, another run's, or of another layout (one line).
    """
    arrays, compute_time_s = checkpoint.load(path, config.to_dict())
    state = RunState(done_blocks=arrays["done_blocks"].astype(np.int64), finished=arrays["finished"].astype(bool),
                     reached=arrays["reached"].astype(bool), tally=arrays["tally"].astype(np.int64),
                     stats=arrays["stats"].astype(np.int64), compute_time_s=compute_time_s)
    if layout is not None:
        for name in ARRAYS:
            if getattr(state, name).shape != getattr(layout, name).shape:
                raise checkpoint.CheckpointError(
                    f"checkpoint {str(path)!r} holds {name} of shape {getattr(state, name).shape}, this run keeps "
                    f"{getattr(layout, name).shape} (another version's layout); start afresh with --overwrite")
    return state


__all__ = ["ARRAYS", "RunState", "load", "save", "start"]
