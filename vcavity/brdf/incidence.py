"""Which tabulated incident directions serve a query direction, with which weights.

Part of the renderer view of a table (:mod:`vcavity.brdf.table_brdf`, docs/table-api.md). A table's
rows are its incident directions ``(theta_i[j], phi_i[j])``. For a query ``wi``:

- isotropic tables: linear in ``theta_i`` between the two bracketing tabulated values
  (constant beyond the first and last; of rows sharing a ``theta_i`` the first is used),
  each row rotated about ``+z`` by ``phi(wi) - phi_i[j]`` (the BRDF of an isotropic
  surface is invariant under that rotation);
- anisotropic tables: rows are grouped into azimuth columns; bilinear in ``(theta_i,
  phi_i)`` between the two columns around ``phi(wi)`` when they are at most
  :data:`MAX_PHI_GAP` apart, refused (:class:`DirectionNotTabulated`) otherwise, and never
  rotated. A normal-incidence row belongs to every column.
"""

from __future__ import annotations

import numpy as np

_TWO_PI = 2.0 * np.pi
#: Anisotropic tables interpolate between tabulated azimuths at most this far apart.
MAX_PHI_GAP = 0.5 * np.pi
_PHI_MATCH = 1e-9  # rad: an azimuth this close to a tabulated one is that one
_NORMAL = 1e-12  # rad: theta_i this small is normal incidence (any phi_i)


class DirectionNotTabulated(ValueError):
    """An incident direction an anisotropic table has no data for."""


class IncidentRows:
    """Interpolation weights over a table's incident directions.

    Parameters
    ----------
    theta_i, phi_i : array_like (n_i,)
        The table's incident directions, rad.
    isotropic : bool
        Whether any azimuth may be served by rotation.
    path : str or os.PathLike
        Named in error messages.
    """

    def __init__(self, theta_i, phi_i, isotropic, path):
        theta = np.asarray(theta_i, dtype=np.float64)
        phi = np.mod(np.asarray(phi_i, dtype=np.float64), _TWO_PI)
        self.isotropic = bool(isotropic)
        self.path = path
        if self.isotropic:  # one row per distinct theta_i (the first); any phi_i serves
            thetas, rows = np.unique(theta, return_index=True)
            self._columns = [(0.0, thetas, rows)]
            self._phi_i = phi
        else:
            self._columns = _azimuth_columns(theta, phi)
        self._normal_rows = np.flatnonzero(theta <= _NORMAL)

    def serving(self, wi):
        """Rows, weights (M, 4) and rotation angles (M, 4) serving unit directions ``wi``.

        Weights are 0 for directions with ``wi_z <= 0`` (below the horizon).
        """
        m = wi.shape[0]
        rows = np.zeros((m, 4), dtype=np.int64)
        weights = np.zeros((m, 4))
        up = wi[:, 2] > 0.0
        theta = np.arctan2(np.hypot(wi[:, 0], wi[:, 1]), wi[:, 2])
        # + 0.0 turns -0.0 into +0.0: along the normal, arctan2(0, -0.0) would be pi, not 0,
        # and (-0.0, 0.0, 1.0) (e.g. a mirrored or negated vector) must read as (0, 0, 1)
        phi = np.mod(np.arctan2(wi[:, 1] + 0.0, wi[:, 0] + 0.0), _TWO_PI)
        if self.isotropic:
            _, thetas, table_rows = self._columns[0]
            rows[:, :2], weights[:, :2] = _theta_bracket(thetas, table_rows, theta)
            angle = phi[:, None] - self._phi_i[rows]  # rotate o by -angle into row j's frame
        else:
            normal = up & (theta <= _NORMAL) if self._normal_rows.size else np.zeros(m, bool)
            rows[normal, 0] = self._normal_rows[0] if self._normal_rows.size else 0
            weights[normal, 0] = 1.0
            rest = up & ~normal
            self._anisotropic(theta[rest], phi[rest], rows, weights, np.flatnonzero(rest))
            angle = np.zeros((m, 4))  # no symmetry to use: o stays in the world frame
        weights[~up] = 0.0
        return rows, weights, angle

    def _anisotropic(self, theta, phi, rows, weights, where):
        """Bilinear (theta_i, phi_i) weights between tabulated azimuth columns."""
        if where.size == 0:
            return
        column_phi = np.array([c[0] for c in self._columns])
        after = np.searchsorted(column_phi, phi) % column_phi.size
        before = (after - 1) % column_phi.size
        gap = np.mod(column_phi[after] - column_phi[before], _TWO_PI)
        gap = np.where(gap > 0.0, gap, _TWO_PI)  # a single column: the whole circle
        s = np.mod(phi - column_phi[before], _TWO_PI) / gap
        near_before = np.minimum(s, 1.0 - s) * gap <= _PHI_MATCH
        s = np.where(near_before, np.round(s), s)  # snap onto a tabulated azimuth
        bad = (gap > MAX_PHI_GAP + _PHI_MATCH) & ~near_before
        if np.any(bad):
            raise DirectionNotTabulated(
                f"incident azimuth phi_i = {np.degrees(phi[np.argmax(bad)]):.6g} deg is not "
                f"served by anisotropic table {self.path}: tabulated phi_i (deg) "
                f"{', '.join(f'{np.degrees(p):.6g}' for p in column_phi)}; azimuths are "
                f"interpolated only between tabulated ones at most "
                f"{np.degrees(MAX_PHI_GAP):g} deg apart")
        for side, column_index, share in ((0, before, 1.0 - s), (2, after, s)):
            for c, (_, thetas, table_rows) in enumerate(self._columns):
                pick = column_index == c
                r, w = _theta_bracket(thetas, table_rows, theta[pick])
                rows[where[pick], side:side + 2] = r
                weights[where[pick], side:side + 2] = w * share[pick, None]


def _theta_bracket(thetas, rows, theta):
    """Rows and linear weights (M, 2) of the tabulated ``thetas`` (sorted) around ``theta``.

    Constant beyond the first and the last tabulated value.
    """
    if thetas.size == 1:
        return (np.full((theta.size, 2), rows[0]),
                np.column_stack([np.ones(theta.size), np.zeros(theta.size)]))
    k = np.clip(np.searchsorted(thetas, theta, side="right") - 1, 0, thetas.size - 2)
    t = np.clip((theta - thetas[k]) / (thetas[k + 1] - thetas[k]), 0.0, 1.0)
    return np.column_stack([rows[k], rows[k + 1]]), np.column_stack([1.0 - t, t])


def _azimuth_columns(theta, phi):
    """Group an anisotropic table's rows by azimuth: [(phi, sorted thetas, rows)].

    Normal-incidence rows belong to every column (their azimuth is meaningless).
    """
    normal = np.flatnonzero(theta <= _NORMAL)
    oblique = np.flatnonzero(theta > _NORMAL)
    columns = []
    for j in oblique[np.argsort(phi[oblique], kind="stable")]:
        if columns and abs(phi[j] - columns[-1][0]) <= _PHI_MATCH:
            columns[-1][1].append(j)
        else:
            columns.append((phi[j], [j]))
    if len(columns) > 1 and _TWO_PI - columns[-1][0] + columns[0][0] <= _PHI_MATCH:
        columns[0][1].extend(columns.pop()[1])  # 2π - ε and 0 are one azimuth
    if not columns:
        columns = [(0.0, [])]
    result = []
    for azimuth, members in columns:
        members = list(normal[:1]) + sorted(members, key=lambda j: theta[j])
        thetas, first = np.unique(theta[members], return_index=True)
        result.append((azimuth, thetas, np.asarray(members)[first]))
    return result


__all__ = ["DirectionNotTabulated", "IncidentRows", "MAX_PHI_GAP"]
