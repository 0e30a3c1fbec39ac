"""What both layouts of ``--format albedo-lut`` share: which tables a request asks for,
their values and errors from the sweep, and C literals.

A layout (:mod:`vcavity.export.albedo_lut`'s midpoint grid, :mod:`vcavity.export.albedo_cycles`)
says where the sweep's nodes go (``grid``) and how ``E_avg`` integrates them
(``average``, ``average_stderr``); :func:`albedo_tables` computes every table the same way
for both. Plain NumPy.
"""

from __future__ import annotations

import numpy as np

from vcavity.export import ExportRefused
from vcavity.io.schema import order_name
from vcavity.sweep.albedo import albedo, albedo_stderr, stderr_of

#: Table name of the remainder: E (f_inf) minus the listed finite orders.
REST = "rest"


def table_specs(order: int, orders: tuple[int, ...] | None) -> list[tuple[str, int | None]]:
    """``(name, order)`` of each E table a request asks for, in file order.

    Without ``--orders``: ``E_f1`` and ``E`` (``--order``, default f_inf). With
    ``--orders``: ``E_f<k>`` per listed finite order, ``E`` (f_inf) when 0 is listed and
    then, after at least one finite order, ``E_rest`` (order None): ``E`` minus the sum
    of the listed finite orders, so that the listed tables and ``E_rest`` add up to ``E``.

    Parameters
    ----------
    order : int
        ``--order`` (0 = f_inf).
    orders : tuple of int, optional
        ``--orders`` (0 = f_inf), or None.
    """
    if orders is None:
        return [("f1", 1), ("", order)]
    finite = [k for k in orders if k != 0]
    specs = [(f"f{k}", k) for k in finite]
    if 0 in orders:
        specs.append(("", 0))
        if finite:
            specs.append((REST, None))
    return specs


def suffix(name: str) -> str:
    """``"_f1"``, ``"_rest"`` or ``""`` (f_inf / ``--order``): how a table name ends."""
    return f"_{name}" if name else ""


def albedo_tables(sweep, specs, grid, average, average_stderr, shown: str) -> dict:
    """``E<suffix>``, ``E<suffix>_stderr``, ``E_avg<suffix>``, ``E_avg<suffix>_stderr`` of
    every spec of :func:`table_specs` (stderr ones only where the estimator gives an error).

    Parameters
    ----------
    sweep : vcavity.io.sweep_table.SweepData
    specs : list of (str, int or None)
    grid : callable
        ``grid(values of the sweep's grid) -> the layout's array``.
    average, average_stderr : callable
        ``E_avg`` of a layout array, and its standard error from the node errors.
    shown : str
        The sweep as messages name it.

    Raises
    ------
    ExportRefused
        Non-finite albedos although every point is done (a damaged file).
    """
    estimator = str(sweep.attrs.get("estimator", "analog"))
    paths = grid(np.asarray(sweep.data["paths"], dtype=np.float64))
    values, errors = {}, {}
    for name, order in specs:
        if order is None:  # the remainder: every exit not in a listed finite order
            finite = [grid(albedo(sweep, k)) for n, k in specs if k not in (None, 0)]
            values[name] = values[""] - np.sum(finite, axis=0)
            # a fraction of independent paths where the estimator makes E one (analog, and
            # exact-f1 beyond order 1): the binomial rule of a simulated order
            errors[name] = stderr_of(estimator, 2, values[name], None, paths)
            continue
        values[name] = grid(albedo(sweep, order))
        if not np.all(np.isfinite(values[name])):
            raise ExportRefused(f"sweep {shown}: albedo of {order_name(order)} holds non-finite values "
                                "although every point is done: the file is damaged")
        error = albedo_stderr(sweep, order)
        errors[name] = None if error is None else grid(error)
    # file order as before --orders existed: the E tables, their errors, the averages, theirs
    tables = {f"E{suffix(name)}": values[name] for name, _ in specs}
    tables.update({f"E{suffix(name)}_stderr": errors[name] for name, _ in specs if errors[name] is not None})
    tables.update({f"E_avg{suffix(name)}": average(values[name]) for name, _ in specs})
    tables.update({f"E_avg{suffix(name)}_stderr": average_stderr(errors[name]) for name, _ in specs
                   if errors[name] is not None})
    return tables


def orders_label(specs) -> str:
    """The tables' orders for metadata: ``f1, f2, f_inf, rest (f_inf minus f1 + f2)``."""
    finite = [order_name(k) for _, k in specs if k not in (None, 0)]
    words = [order_name(k) if k is not None else f"rest (f_inf minus {' + '.join(finite)})" for _, k in specs]
    return ", ".join(words)


def select(sweep, values: np.ndarray, rows, columns, names=("alpha", "theta_i_deg")) -> np.ndarray:
    """A grid array reduced to ``[rows, columns]`` of the axes ``names``: the other
    (single-valued) axes dropped, then the positions ``rows`` of the first axis and
    ``columns`` of the second picked, in that order."""
    axes = [a.name for a in sweep.axes]
    index = tuple(slice(None) if n in names else 0 for n in axes)
    reduced = np.asarray(values)[index]
    if axes.index(names[0]) > axes.index(names[1]):  # file order (second, first)
        reduced = reduced.T
    return reduced[np.ix_(rows, columns)]


def c_float(value: float) -> str:
    """``%.9g`` (round-trips a float) as a C float literal: ``0.5f``, ``1.0f``, ``1e-05f``."""
    text = f"{float(value):.9g}"
    if not any(c in text for c in ".e"):
        text += ".0"
    return text + "f"


def c_array(name: str, values: np.ndarray, dims: str, per_line: int | None = None) -> str:
    """``static const float name dims = {...};``: a 1-D array on one line (or ``per_line``
    values a line), a 2-D one a row a line in braces."""
    values = np.asarray(values)
    if values.ndim == 1 and per_line is None:
        body = ", ".join(c_float(v) for v in values)
        return f"static const float {name}{dims} = {{{body}}};\n"
    if values.ndim == 1:
        rows = ",\n".join("    " + ", ".join(c_float(v) for v in values[i:i + per_line])
                          for i in range(0, values.size, per_line))
        return f"static const float {name}{dims} = {{\n{rows}\n}};\n"
    rows = ",\n".join("    {" + ", ".join(c_float(v) for v in row) + "}" for row in values)
    return f"static const float {name}{dims} = {{\n{rows}\n}};\n"
