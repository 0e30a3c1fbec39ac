"""A MERL isotropic BRDF reader written from the format's description, in plain NumPy.

Nothing of ``vcavity`` is imported. The format (Matusik et al. 2003, the ``BRDFRead.cpp``
reader of the MERL database):

- header: three little-endian int32, the bin counts ``90, 90, 180`` of theta_h, theta_d,
  phi_d;
- then ``3 * 90 * 90 * 180`` little-endian float64: every red value, then every green,
  then every blue; the value of bin ``(i, j, k)`` is at ``k + 180 * (j + 90 * i)`` in its
  channel, and the reader multiplies it by the channel's scale (:data:`SCALES`);
  negative values mark bins without data;
- a direction pair maps to half/difference angles (Rusinkiewicz 1998): ``h`` is the
  normalised ``wi + wo``, ``theta_h = acos(h_z)``, ``phi_h = atan2(h_y, h_x)``, and the
  difference vector is ``wi`` rotated by ``-phi_h`` about the normal ``z`` and then by
  ``-theta_h`` about the binormal ``y``; ``theta_d = acos(d_z)``, ``phi_d = atan2(d_y, d_x)``;
- bins: ``i = floor(sqrt(theta_h / (pi/2)) * 90)``, ``j = floor(theta_d / (pi/2) * 90)``,
  ``k = floor(phi_d / pi * 180)`` after ``phi_d < 0 -> phi_d + pi`` (reciprocity), each
  clamped to its range.

Rotations are Rodrigues' formula about an axis, as the original reader's
``rotate_vector``; bin centres go back to directions by the inverse rotations.
"""

from __future__ import annotations

import numpy as np

DIMS = (90, 90, 180)  # theta_h, theta_d, phi_d
SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
HEADER_BYTES = 12
FILE_BYTES = HEADER_BYTES + 3 * 8 * DIMS[0] * DIMS[1] * DIMS[2]

_NORMAL = np.array([0.0, 0.0, 1.0])
_BINORMAL = np.array([0.0, 1.0, 0.0])


def read(path):
    """Header dims and the raw stored values of a MERL file.

    Returns
    -------
    dims : tuple of int
    raw : ndarray (3, 90, 90, 180)
        Stored values per channel (red, green, blue), indexed ``[c, i, j, k]``, unscaled.
    """
    data = open(path, "rb").read()
    dims = tuple(int(d) for d in np.frombuffer(data[:HEADER_BYTES], dtype="<i4"))
    values = np.frombuffer(data[HEADER_BYTES:], dtype="<f8")
    n = dims[0] * dims[1] * dims[2]
    if values.size != 3 * n:
        raise ValueError(f"{path}: {values.size} values, expected {3 * n}")
    # index k + 180 (j + 90 i) is C order over (i, j, k)
    return dims, values.reshape(3, dims[0], dims[1], dims[2])


def scaled(raw):
    """Reader values: raw times the channel scales, ``(3, ...)``."""
    return raw * SCALES.reshape((3,) + (1,) * (raw.ndim - 1))


def rotate(vectors, axis, angle):
    """Rodrigues: ``v cos a + axis (axis . v)(1 - cos a) + (axis x v) sin a``, vectorised."""
    v = np.asarray(vectors, dtype=np.float64)
    angle = np.asarray(angle, dtype=np.float64)[..., None]
    dot = np.sum(v * axis, axis=-1, keepdims=True)
    return (v * np.cos(angle) + axis * dot * (1.0 - np.cos(angle))
            + np.cross(np.broadcast_to(axis, v.shape), v) * np.sin(angle))


def half_diff(wi, wo):
    """``theta_h, phi_h, theta_d, phi_d`` of direction pairs ``(..., 3)``."""
    wi = wi / np.linalg.norm(wi, axis=-1, keepdims=True)
    wo = wo / np.linalg.norm(wo, axis=-1, keepdims=True)
    h = 0.5 * (wi + wo)
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    theta_h = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
    phi_h = np.arctan2(h[..., 1], h[..., 0])
    d = rotate(rotate(wi, _NORMAL, -phi_h), _BINORMAL, -theta_h)
    theta_d = np.arccos(np.clip(d[..., 2], -1.0, 1.0))
    phi_d = np.arctan2(d[..., 1], d[..., 0])
    return theta_h, phi_h, theta_d, phi_d


def bin_indices(theta_h, theta_d, phi_d):
    """Bin ``(i, j, k)`` of half/difference angles, as the reader computes it."""
    with np.errstate(invalid="ignore"):
        i = np.floor(np.sqrt(np.maximum(theta_h, 0.0) / (0.5 * np.pi)) * DIMS[0])
    j = np.floor(theta_d / (0.5 * np.pi) * DIMS[1])
    phi = np.where(phi_d < 0.0, phi_d + np.pi, phi_d)
    k = np.floor(phi / np.pi * DIMS[2])
    return tuple(np.clip(x, 0, n - 1).astype(np.int64) for x, n in zip((i, j, k), DIMS))


def bin_centre_angles(i, j, k):
    """Half/difference angles of bin centres (``+ 1/2`` in each bin's own coordinate)."""
    theta_h = (0.5 * np.pi) * ((np.asarray(i) + 0.5) / DIMS[0]) ** 2
    theta_d = (0.5 * np.pi) * (np.asarray(j) + 0.5) / DIMS[1]
    phi_d = np.pi * (np.asarray(k) + 0.5) / DIMS[2]
    return theta_h, theta_d, phi_d


def directions(theta_h, phi_h, theta_d, phi_d):
    """``(wi, wo)`` of half/difference angles: the inverse rotations of :func:`half_diff`."""
    theta_h, phi_h, theta_d, phi_d = np.broadcast_arrays(theta_h, phi_h, theta_d, phi_d)
    d = np.stack([np.sin(theta_d) * np.cos(phi_d), np.sin(theta_d) * np.sin(phi_d),
                  np.cos(theta_d)], axis=-1)
    mirrored = d * np.array([-1.0, -1.0, 1.0])  # d reflected about the half vector (z here)
    wi = rotate(rotate(d, _BINORMAL, theta_h), _NORMAL, phi_h)
    wo = rotate(rotate(mirrored, _BINORMAL, theta_h), _NORMAL, phi_h)
    return wi, wo


def lookup(raw, wi, wo):
    """Reader values ``(3, ...)`` of the bins of direction pairs (nearest bin, no blending)."""
    theta_h, _, theta_d, phi_d = half_diff(wi, wo)
    i, j, k = bin_indices(theta_h, theta_d, phi_d)
    return scaled(raw[:, i, j, k])
