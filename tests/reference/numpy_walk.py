"""The V-groove random walk in plain, vectorised NumPy: the baseline a researcher writes first.

An independent implementation of the analog walk of docs/physics.md sec. 5 (no vcavity
code: the groove sampler, the geometry, the facet events and the binning are written
here from the formulas, with the helpers of :mod:`tests.reference.materials` and
:mod:`tests.reference.sensor`), used two ways:

- as a statistical reference for the kernel (tests/kernels/test_numpy_walk.py): the same
  material and incidence give counts per (order, cell) that agree within error bars;
- as the throughput baseline of scripts/bench_throughput.py (the jitted
  kernel is to be at least 20x faster single-threaded).

How it differs from the kernel, on purpose: the groove normal is sampled with ``cos``/``sin``
of ``2 pi u2`` (H sec. 5, stretched slopes) instead of a disk point; positions are
Cartesian ``(x', z)`` and every segment intersects the three lines of the groove's
triangle (snapped onto the line it hits); the body re-emission draws a cosine-weighted
direction from ``sqrt(u)`` and an azimuth instead of a disk point, and is accepted with
probability ``T(mu)`` (physics.md sec. 4); exits are binned with ``arctan2``
(:func:`tests.reference.sensor.cells_of`). All paths of a chunk advance together, one
bounce per iteration, with boolean masks for the paths still in the groove.

Distributions: beckmann and ggx (isotropic or anisotropic). Facets: mirror and the
interfaced Lambertian with any ``kd``, ``eta`` (so its dielectric and Lambertian limits).
"""

from __future__ import annotations

import math

import numpy as np

from tests.reference import materials as mat
from tests.reference import sensor as sen

CHUNK = 1 << 17  # paths advanced together (memory ~ 40 float64 arrays of this length)


def sample_grooves(material: mat.Material, u1, u2):
    """``(tan theta_m, phi_m)`` with pdf ``D(m)(m.n)`` by stretched slopes (H sec. 5, physics.md sec. 2).

    Slope ``(alpha_x r cos 2 pi u2, alpha_y r sin 2 pi u2)`` with ``r^2 = -log(1 - u1)``
    (Beckmann) or ``u1 / (1 - u1)`` (GGX); the normal is ``normalize(-slope, 1)``.
    """
    if material.distribution == "beckmann":
        r = np.sqrt(-np.log1p(-u1))
    elif material.distribution == "ggx":
        r = np.sqrt(u1 / (1.0 - u1))
    else:
        raise ValueError(f"numpy_walk: distribution {material.distribution!r} not implemented")
    phi = 2.0 * math.pi * u2
    sx = material.roughness["alpha_x"] * r * np.cos(phi)
    sy = material.roughness["alpha_y"] * r * np.sin(phi)
    return np.hypot(sx, sy), np.arctan2(-sy, -sx)


def _trace_chunk(material, incident, n, rng, resolution, max_order, max_bounces, counts, totals, a_body):
    ix, iy, iz = incident
    tan_m, phi_m = sample_grooves(material, rng.random(n), rng.random(n))
    cos_t = 1.0 / np.sqrt(1.0 + tan_m * tan_m)
    sin_t = tan_m * cos_t
    c, s = np.cos(phi_m), np.sin(phi_m)
    # d = -i in the groove frame x' = (c, s, 0), y' = (-s, c, 0)
    dx = -(ix * c + iy * s)
    dy = -(-ix * s + iy * c)
    dz = np.full(n, -iz)
    px = rng.uniform(-1.0, 1.0, n)  # entry point on the opening
    pz = np.zeros(n)
    surface = np.zeros(n, np.int8)  # 0 opening, 1 left wall, 2 right wall
    bounces = np.zeros(n, np.int64)
    alive = np.ones(n, bool)
    exited = np.zeros(n, bool)
    while alive.any():
        a = np.flatnonzero(alive)
        t, x, z, vx, vz, on = tan_m[a], px[a], pz[a], dx[a], dz[a], surface[a]
        # lines: left  t x + z + t = 0, right -t x + z + t = 0, opening z = 0
        with np.errstate(divide="ignore", invalid="ignore"):
            rate_l = t * vx + vz
            rate_r = -t * vx + vz
            s_l = np.where((rate_l < 0.0) & (on != 1), -(t * x + z + t) / rate_l, np.inf)
            s_r = np.where((rate_r < 0.0) & (on != 2), -(-t * x + z + t) / rate_r, np.inf)
            s_o = np.where((vz > 0.0) & (on != 0), -z / vz, np.inf)
        s_best = np.minimum(np.minimum(s_l, s_r), s_o)
        hit = np.where(s_o == s_best, 0, np.where(s_l == s_best, 1, 2)).astype(np.int8)
        x = x + np.maximum(s_best, 0.0) * vx
        degenerate = ~np.isfinite(s_best)
        leaves = (hit == 0) & ~degenerate
        exited[a[leaves]] = True
        alive[a[leaves | degenerate]] = False
        totals["degenerate"] += int(degenerate.sum())
        wall = ~(leaves | degenerate)
        capped = wall & (bounces[a] >= max_bounces)
        alive[a[capped]] = False
        totals["truncated"] += int(capped.sum())
        wall &= ~capped
        b = a[wall]
        xb, hb = x[wall], hit[wall]
        px[b] = np.where(hb == 1, np.clip(xb, -1.0, 0.0), np.clip(xb, 0.0, 1.0))
        pz[b] = -tan_m[b] * (1.0 - np.abs(px[b]))  # snapped onto the wall line
        surface[b] = hb
        bounces[b] += 1
        # the facet event (physics.md sec. 4) with the wall normal n = (+-sin t, 0, cos t)
        nx = np.where(hb == 1, sin_t[b], -sin_t[b])
        nz = cos_t[b]
        cos_in = -(dx[b] * nx + dz[b] * nz)
        if material.is_mirror:
            reflect = np.ones(b.size, bool)
        else:
            reflect = rng.random(b.size) < mat.fresnel_reflectance(cos_in, material.eta)
        r = b[reflect]
        dx[r] += 2.0 * cos_in[reflect] * nx[reflect]
        dz[r] += 2.0 * cos_in[reflect] * nz[reflect]
        into_body = ~reflect
        if into_body.any():
            enter = b[into_body]
            emerges = rng.random(enter.size) < a_body
            alive[enter[~emerges]] = False
            totals["absorbed"] += int((~emerges).sum())
            e = enter[emerges]
            ex, ez = nx[into_body][emerges], nz[into_body][emerges]
            _emerge(material, e, ex, ez, dx, dy, dz, rng)
    w = np.flatnonzero(exited)
    k = bounces[w]
    world = np.stack([dx[w] * c[w] - dy[w] * s[w], dx[w] * s[w] + dy[w] * c[w], dz[w]], axis=-1)
    cells = sen.cells_of(world, resolution)
    slot = np.where(k <= max_order, k, 0)
    np.add.at(counts, (slot, cells), 1)


def _emerge(material, idx, nx, nz, dx, dy, dz, rng):
    """Cosine-weighted directions about (nx, 0, nz), accepted with probability T(mu)."""
    todo = np.arange(idx.size)
    while todo.size:
        u = rng.random(todo.size)
        phi = 2.0 * math.pi * rng.random(todo.size)
        mu = np.sqrt(1.0 - u)
        if material.eta > 1.0:
            keep = rng.random(todo.size) < mat.fresnel_transmittance(mu, material.eta)
        else:
            keep = np.ones(todo.size, bool)
        j = todo[keep]
        rho, ph, m = np.sqrt(u[keep]), phi[keep], mu[keep]
        a, bb = rho * np.cos(ph), rho * np.sin(ph)
        # local frame: t1 = (nz, 0, -nx), t2 = (0, 1, 0), n = (nx, 0, nz)
        dx[idx[j]] = a * nz[j] + m * nx[j]
        dy[idx[j]] = bb
        dz[idx[j]] = -a * nx[j] + m * nz[j]
        todo = todo[~keep]


def walk(material: dict, theta_i: float, phi_i: float, n_paths: int, resolution: int, max_order: int,
         max_bounces: int = 10_000, seed: int = 0):
    """Trace ``n_paths`` analog paths; return ``(counts, totals)``.

    Parameters
    ----------
    material : dict
        A config-style ``[material]`` table (see :func:`tests.reference.materials.parse_material`).
    theta_i, phi_i : float
        Incident direction, radians.
    n_paths, resolution, max_order, max_bounces : int
        As in a run config (``resolution`` is the sensor's N).
    seed : int
        Seed of the NumPy generator (PCG64).

    Returns
    -------
    counts : ndarray, shape (max_order + 1, N^2), int64
        Exits per order slot (slot 0: more than ``max_order`` bounces) and cell, the
        layout of the kernel's per-slot counts.
    totals : dict
        ``absorbed``, ``truncated``, ``degenerate`` path counts.
    """
    m = mat.parse_material(material)
    a_body = mat.emergence_probability(m.kd, m.eta) if m.has_body else 0.0
    incident = (math.sin(theta_i) * math.cos(phi_i), math.sin(theta_i) * math.sin(phi_i), math.cos(theta_i))
    rng = np.random.default_rng(seed)
    counts = np.zeros((max_order + 1, resolution * resolution), np.int64)
    totals = {"absorbed": 0, "truncated": 0, "degenerate": 0}
    for start in range(0, n_paths, CHUNK):
        _trace_chunk(m, incident, min(CHUNK, n_paths - start), rng, resolution, max_order, max_bounces,
                     counts, totals, a_body)
    return counts, totals
