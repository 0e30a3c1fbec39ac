"""The directional albedo a sweep file stores, per bounce order, and its standard error.

A sweep stores ``albedo(grid..., order)`` but no standard error of it. Where the estimator
makes the albedo a fraction of independent paths, the error follows from the albedo and
the paths of the direction alone (docs/hdf5-format.md, *The cell value*):

- ``analog``: ``albedo[k] = n_k / N`` with ``n_k`` the paths that left with order ``k``
  (``k = 0``: every exit) out of ``N = paths``, a binomial count, so its standard error is
  ``sqrt(a (1 - a) / N)``, exactly the formula of a binomial proportion;
- ``exact-f1``: order 1 is the analytic single-bounce model (no statistical error; its
  quadrature error is not stored per direction and is neglected, the run keeps it below a
  tenth of each cell's statistical error); orders ``k >= 2`` are binomial as above; f_inf is
  the model plus the binomial fraction ``p = albedo[0] - albedo[1]`` of the paths that left
  after two or more bounces, so its error is ``sqrt(p (1 - p) / N)``;
- ``paper`` (weighted paths): the error needs the per-path weights summed over all cells,
  which the sweep does not keep: none.

Plain NumPy (used by ``vcavity plot --kind sweep`` and ``vcavity export --format albedo-lut``).
"""

from __future__ import annotations

import numpy as np

#: Estimator -> how the albedo's standard error is obtained (one line, for metadata and titles).
STDERR_RULES = {
    "analog": "binomial sqrt(a (1 - a) / paths): the albedo is a fraction of independent paths",
    "exact-f1": "f1 analytic (no statistical error; quadrature error neglected); other orders binomial "
                "sqrt(p (1 - p) / paths) of the simulated fraction p (f_inf: p = E_inf - E_f1)",
}


def stderr_rule(estimator: str) -> str:
    """How :func:`albedo_stderr` obtains the error for ``estimator`` (one line)."""
    return STDERR_RULES.get(estimator, f"not available: the sweep stores no albedo error for estimator "
                                       f"{estimator!r} (weighted paths)")


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


def _binomial(fraction, paths):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(np.clip(fraction * (1.0 - fraction), 0.0, None) / paths)


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
        ``analog``, ``exact-f1``, ...: the table's or sweep's ``estimator`` attribute.
    order : int
        Bounce order of ``value``, 0 = f_inf.
    value, value_f1 : array_like
        Albedo of ``order`` and of order 1 (None when absent), per direction.
    paths : array_like
        Paths of each direction (0 where nothing is done: NaN comes out).

    Returns
    -------
    ndarray or None
        None where the estimator gives no error (module docstring).
    """
    if estimator not in STDERR_RULES:
        return None
    paths = np.asarray(paths, dtype=np.float64)
    paths = np.where(paths > 0, paths, np.nan)  # points not done: NaN, not a division by zero
    value = np.asarray(value, dtype=np.float64)
    if estimator == "exact-f1":
        if int(order) == 1:
            return None
        if int(order) == 0:
            if value_f1 is None:
                return None
            value = value - np.asarray(value_f1, dtype=np.float64)  # the simulated part: exits after >= 2 bounces
    return _binomial(value, paths)


__all__ = ["STDERR_RULES", "albedo", "albedo_stderr", "order_position", "stderr_of", "stderr_rule"]
