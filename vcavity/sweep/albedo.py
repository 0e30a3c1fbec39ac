"""The directional albedo a sweep file stores, per bounce order, and its standard error.

A sweep stores ``albedo(grid..., order)`` but no standard error of it. Where the estimator
makes the albedo a fraction of independent paths, the error follows from the albedo and
the paths of the direction alone (docs/hdf5-format.md, *The cell value*); each estimator
says how (its ``STDERR_RULE`` and ``albedo_stderr``, :mod:`vcavity.estimators.registry`):
binomial ``sqrt(a (1 - a) / N)`` for the analog estimator, the same for the simulated part
of exact-f1's orders (its f1 is analytic), none for the paper estimator (the error needs
the per-path weights summed over all cells) or for the exact one's models.

Plain NumPy (used by ``vcavity plot --kind sweep`` and ``vcavity export --format albedo-lut``).
"""

from __future__ import annotations

import numpy as np

from vcavity.estimators import registry as estimators


def stderr_rule(estimator: str) -> str:
    """How :func:`albedo_stderr` obtains the error for ``estimator`` (one line)."""
    module = estimators.find(estimator)
    if module is None:
        return f"not available: the sweep's estimator {estimator!r} is not one this vcavity knows"
    return module.STDERR_RULE


def order_position(sweep, order: int) -> int | None:
    """Position of bounce ``order`` (0 = f_inf) on the sweep's order axis, None if absent."""
    orders = [int(k) for k in sweep.order]
    return orders.index(int(order)) if int(order) in orders else None


def albedo(sweep, order: int) -> np.ndarray:
    """``albedo(grid...)`` of bounce ``order`` (NaN where a point is not done).

    Raises
    ------
    KeyError
        The sweep has no such order.
    """
    position = order_position(sweep, order)
    if position is None:
        raise KeyError(f"order {order} is not in the sweep")
    return np.asarray(sweep.data["albedo"][..., position], dtype=np.float64)


def albedo_stderr(sweep, order: int) -> np.ndarray | None:
    """Standard error of :func:`albedo` (shape of the grid), or None where the sweep's
    estimator leaves none (module docstring: per estimator, per order).

    Parameters
    ----------
    sweep : vcavity.io.sweep_table.SweepData
    order : int
        Bounce order, 0 = f_inf.
    """
    has_f1 = order_position(sweep, 1) is not None
    return stderr_of(str(sweep.attrs.get("estimator", "analog")), order, albedo(sweep, order),
                     albedo(sweep, 1) if has_f1 else None, sweep.data["paths"])


def stderr_of(estimator: str, order: int, value, value_f1, paths) -> np.ndarray | None:
    """The rule of :func:`albedo_stderr` on arrays: of one table's or one sweep's albedos.

    Parameters
    ----------
    estimator : str
        The table's or sweep's ``estimator`` attribute.
    order : int
        Bounce order of ``value``, 0 = f_inf.
    value, value_f1 : array_like
        Albedo of ``order`` and of order 1 (None when absent), per direction.
    paths : array_like
        Paths of each direction (0 where nothing is done: NaN comes out).

    Returns
    -------
    ndarray or None
        None where the estimator gives no error (or is not known here).
    """
    module = estimators.find(estimator)
    return None if module is None else module.albedo_stderr(order, value, value_f1, paths)


__all__ = ["albedo", "albedo_stderr", "order_position", "stderr_of", "stderr_rule"]
