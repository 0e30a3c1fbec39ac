"""The Smith random walk (Heitz et al. 2016) in plain, vectorised NumPy, independent of vcavity.

An independent implementation of the walk of docs/physics.md sec. 15, used as a
statistical reference for the kernel (tests/kernels/test_smith_reference.py). Nothing
of the package is imported; the helpers are :mod:`tests.reference.materials` (Fresnel,
the body's emergence probability) and :mod:`tests.reference.sensor` (binning). How it
differs from the kernel, on purpose:

- **Real heights.** The surface heights are standard normal (``C1 = Φ``), carried as
  heights ``h`` and converted with ``scipy.special.log_ndtr`` / ``ndtri_exp``; the kernel
  instead carries ``c = C1(h)`` (the uniform height distribution). The result must not
  depend on the height distribution (Heitz 2016 sec. 4.1), so agreement also tests that.
- **Exponential free paths in "height depth".** With ``τ(h) = -ln C1(h)``, Smith's
  masking of a ray travelling up is ``G1(w, h) = C1(h)^Λ(w) = exp(-Λ(w) τ(h))`` (Heitz
  2016 eq. 5), and the intersection law ``P(h' > x) = (C1(h)/C1(x))^Λ(w)`` is
  ``exp(-Λ(w) (τ(h) - τ(x)))``: memoryless in ``τ`` with rate ``Λ(w)`` (derived by us).
  So one exponential deviate ``E`` decides both: the ray escapes if ``E >= Λ τ(h)``, else
  it meets the surface at ``τ' = τ - E/Λ``. Travelling down, ``P(h' < x) =
  (C1(x)/C1(h))^(1 + Λ(-w))`` (Heitz 2016 sec. 4.1) gives ``τ' = τ + E/(1 + Λ(-w))``.
  The kernel inverts the same laws from one uniform in ``c`` space.
- **Λ** written here from its closed forms (H eq. 72 for GGX, eq. 69 for Beckmann, with
  ``erfc``), anisotropic through the projected roughness (H eq. 80).
- **Visible normals by rejection, not by Heitz's samplers.** ``D_v(m) ∝ <v, m>+ D(m)``
  (H eq. 16) is, over slopes ``s`` (``m = normalize(-s_x, -s_y, 1)``), ``P22(s) (v_z -
  s.v_xy)+`` (H eq. 108: ``P22 d²s = D(m)(m.n) dω_m``, and ``<v, m>/(m.n) = v_z - s.v_xy``).
  With ``s = (α_x r cos ψ, α_y r sin ψ)``, ``r`` the unit-roughness slope length,
  ``|s.v_xy| <= r A``, ``A = |(α_x v_x, α_y v_y)|``, so ``(v_z - s.v_xy)+ <= B (1 + r)``,
  ``B = max(|v_z|, A)``. Proposals come from ``P22(s)(1 + r)``, the mixture of
  ``P22`` (weight 1) and ``P22 r`` (weight ``E[r]``), and are accepted with probability
  ``(v_z - s.v_xy)+ / (B (1 + r))``: exact for any ``v``, also below the horizon (a ray
  travelling up). Unit-roughness radial laws, each inverted or drawn by hand:
  Beckmann ``P22 = exp(-r²)/π``: ``r² ~ Exp(1)``; ``P22 r``: ``r² ~ Gamma(3/2)``;
  ``E[r] = √π/2``. GGX ``P22 = 1/(π (1 + r²)²)``: ``r² = u/(1 - u)``; ``P22 r``: ``r =
  tan θ`` with ``θ`` of density ``∝ sin²θ`` on ``(0, π/2)`` (by rejection); ``E[r] = π/2``.
- **Facets** from physics.md sec. 4 as a specification: mirror ``w + 2 c m``; the
  interfaced Lambertian reflects with probability ``F(c)``, else enters, emerges with
  probability ``a = kd (1 - r_i)/(1 - kd r_i)`` (else absorbed) in a cosine-weighted
  direction about ``m`` accepted with probability ``T(μ)``, in a frame built from
  ``m`` here (no turn about ``z``).

All paths of a chunk advance together, one facet event per iteration.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from tests.reference import materials as mat
from tests.reference import sensor as sen

CHUNK = 1 << 16
_MEAN_R = {"beckmann": 0.5 * math.sqrt(math.pi), "ggx": 0.5 * math.pi}  # E[r] of the unit-roughness slope


def smith_lambda(material: mat.Material, v) -> np.ndarray:
    """Smith's ``Λ(v)`` for directions ``v`` (..., 3) with ``v_z > 0`` (H eq. 69, 72, 80).

    ``a = v_z / |(α_x v_x, α_y v_y)|``; GGX ``(sqrt(1 + 1/a²) - 1)/2``; Beckmann
    ``(exp(-a²)/(a √π) - erfc(a))/2``. ``Λ = 0`` straight up.
    """
    v = np.asarray(v, dtype=np.float64)
    ax, ay = material.roughness["alpha_x"], material.roughness["alpha_y"]
    across = np.hypot(ax * v[..., 0], ay * v[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_a = across / v[..., 2]  # 1/a = α_o tan θ
        if material.distribution == "ggx":
            lam = 0.5 * (np.sqrt(1.0 + inv_a * inv_a) - 1.0)
        elif material.distribution == "beckmann":
            a = 1.0 / inv_a
            lam = 0.5 * (np.exp(-a * a) / (a * math.sqrt(math.pi)) - special.erfc(a))
            lam = np.where(a > 26.0, 0.0, lam)  # both terms underflow; Λ < 1e-290
        else:
            raise ValueError(f"smith_walk: distribution {material.distribution!r} not implemented")
    return np.where(across > 0.0, lam, 0.0)


def _unit_radius(distribution: str, weighted: np.ndarray, rng) -> np.ndarray:
    """Unit-roughness slope lengths from ``P22`` (``weighted`` False) or ``P22 r`` (True)."""
    n = weighted.size
    r = np.empty(n)
    plain = ~weighted
    if distribution == "beckmann":
        r[plain] = np.sqrt(rng.standard_exponential(plain.sum()))
        r[weighted] = np.sqrt(rng.standard_gamma(1.5, weighted.sum()))
    else:
        u = rng.random(plain.sum())
        r[plain] = np.sqrt(u / (1.0 - u))
        todo = np.flatnonzero(weighted)
        while todo.size:  # θ with density ∝ sin²θ on (0, π/2), then r = tan θ
            theta = 0.5 * math.pi * rng.random(todo.size)
            keep = rng.random(todo.size) < np.sin(theta) ** 2
            r[todo[keep]] = np.tan(theta[keep])
            todo = todo[~keep]
    return r


def sample_visible(material: mat.Material, v, rng) -> np.ndarray:
    """Unit normals ``m`` (n, 3) with density ``∝ <v, m>+ D(m)`` per row of ``v`` (n, 3), by rejection."""
    v = np.asarray(v, dtype=np.float64)
    ax, ay = material.roughness["alpha_x"], material.roughness["alpha_y"]
    bound = np.maximum(np.abs(v[:, 2]), np.hypot(ax * v[:, 0], ay * v[:, 1]))
    out = np.empty_like(v)
    todo = np.arange(v.shape[0])
    mean_r = _MEAN_R[material.distribution]
    while todo.size:
        k = max(1, min(64, CHUNK // todo.size))  # proposals per path this round
        idx = np.repeat(todo, k)
        weighted = rng.random(idx.size) < mean_r / (1.0 + mean_r)
        r = _unit_radius(material.distribution, weighted, rng)
        psi = 2.0 * math.pi * rng.random(idx.size)
        sx, sy = ax * r * np.cos(psi), ay * r * np.sin(psi)
        projected = v[idx, 2] - sx * v[idx, 0] - sy * v[idx, 1]  # <v, m>/(m.n)
        accept = rng.random(idx.size) * bound[idx] * (1.0 + r) < projected
        # the first accepted proposal of each path
        first = np.flatnonzero(accept)
        first = first[np.unique(idx[first], return_index=True)[1]]
        norm = np.sqrt(1.0 + sx[first] ** 2 + sy[first] ** 2)
        out[idx[first]] = np.stack([-sx[first], -sy[first], np.ones(first.size)], axis=-1) / norm[:, None]
        todo = np.setdiff1d(todo, idx[first], assume_unique=True)
    return out


def _emerge(material: mat.Material, m, rng) -> np.ndarray:
    """Directions about normals ``m`` (n, 3): cosine-weighted, accepted with probability T(μ)."""
    n = m.shape[0]
    # a frame (t1, t2, m): t1 = normalize(m x e), e the axis least aligned with m
    e = np.zeros_like(m)
    e[np.arange(n), np.argmin(np.abs(m), axis=1)] = 1.0
    t1 = np.cross(m, e)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(m, t1)
    out = np.empty_like(m)
    todo = np.arange(n)
    while todo.size:
        mu = np.sqrt(rng.random(todo.size))  # pdf 2 μ
        psi = 2.0 * math.pi * rng.random(todo.size)
        if material.eta > 1.0:
            keep = rng.random(todo.size) < mat.fresnel_transmittance(mu, material.eta)
        else:
            keep = np.ones(todo.size, bool)
        j, mu, psi = todo[keep], mu[keep], psi[keep]
        sin = np.sqrt(1.0 - mu * mu)
        out[j] = (mu[:, None] * m[j] + (sin * np.cos(psi))[:, None] * t1[j]
                  + (sin * np.sin(psi))[:, None] * t2[j])
        todo = todo[~keep]
    return out


def _trace_chunk(material, incident, n, rng, resolution, max_order, max_bounces, counts, totals, a_body):
    w = np.tile(-np.asarray(incident, dtype=np.float64), (n, 1))
    h = np.full(n, np.inf)  # standard normal heights; the light starts above the surface
    k = np.zeros(n, np.int64)
    alive = np.arange(n)
    while alive.size:
        wa, ha = w[alive], h[alive]
        depth = -special.log_ndtr(ha)  # τ = -ln C1(h) >= 0
        e = rng.standard_exponential(alive.size)
        up, down = wa[:, 2] > 0.0, wa[:, 2] < 0.0
        lam_up = smith_lambda(material, np.where(up[:, None], wa, [0.0, 0.0, 1.0]))
        lam_down = smith_lambda(material, np.where(down[:, None], -wa, [0.0, 0.0, 1.0]))
        escape = up & (e >= lam_up * depth)
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.where(up, depth - e / lam_up, np.where(down, depth + e / (1.0 + lam_down), depth))
        leaving = alive[escape]
        if leaving.size:
            order = k[leaving]
            cells = sen.cells_of(w[leaving], resolution)
            np.add.at(counts, (np.where(order <= max_order, order, 0), cells), 1)
        hits = ~escape
        alive, wa, depth = alive[hits], wa[hits], depth[hits]
        capped = k[alive] == max_bounces
        totals["truncated"] += int(capped.sum())
        alive, wa, depth = alive[~capped], wa[~capped], depth[~capped]
        h[alive] = special.ndtri_exp(-depth)  # the height met (a real height, kept as such)
        k[alive] += 1
        m = sample_visible(material, -wa, rng)
        cos_in = -np.sum(wa * m, axis=1)
        if material.is_mirror:
            reflect = np.ones(alive.size, bool)
        elif material.eta > 1.0:
            reflect = rng.random(alive.size) < mat.fresnel_reflectance(cos_in, material.eta)
        else:
            reflect = np.zeros(alive.size, bool)
        w[alive[reflect]] = wa[reflect] + 2.0 * cos_in[reflect, None] * m[reflect]
        enter = ~reflect
        emerges = enter.copy()
        emerges[enter] = rng.random(enter.sum()) < a_body
        absorbed = enter & ~emerges
        totals["absorbed"] += int(absorbed.sum())
        if emerges.any():
            w[alive[emerges]] = _emerge(material, m[emerges], rng)
        alive = alive[~absorbed]


def walk(material: dict, theta_i: float, phi_i: float, n_paths: int, resolution: int, max_order: int,
         max_bounces: int = 10_000, seed: int = 0):
    """Trace ``n_paths`` analog paths of the Smith walk; return ``(counts, totals)``.

    Parameters
    ----------
    material : dict
        A config-style ``[material]`` table (:func:`tests.reference.materials.parse_material`;
        ``microsurface`` is ignored): beckmann or ggx, iso- or anisotropic; mirror or
        interfaced Lambertian facets (any ``kd``, ``eta``).
    theta_i, phi_i : float
        Incident direction, radians.
    n_paths, resolution, max_order, max_bounces : int
        As in a run config (``resolution`` is the sensor's N). A path needing facet
        event ``max_bounces + 1`` is truncated, as in the kernel.
    seed : int
        Seed of the NumPy generator (PCG64).

    Returns
    -------
    counts : ndarray, shape (max_order + 1, N^2), int64
        Exits per order slot (slot 0: more than ``max_order`` events) and cell.
    totals : dict
        ``absorbed`` and ``truncated`` path counts.
    """
    raw = {key: value for key, value in material.items() if key != "microsurface"}
    m = mat.parse_material(raw)
    if m.facet not in ("mirror", "interfaced_lambertian"):
        raise ValueError(f"smith_walk: facet {m.facet!r} not implemented")
    a_body = mat.emergence_probability(m.kd, m.eta) if m.has_body else 0.0
    incident = (math.sin(theta_i) * math.cos(phi_i), math.sin(theta_i) * math.sin(phi_i), math.cos(theta_i))
    rng = np.random.default_rng(seed)
    counts = np.zeros((max_order + 1, resolution * resolution), np.int64)
    totals = {"absorbed": 0, "truncated": 0}
    for start in range(0, n_paths, CHUNK):
        _trace_chunk(m, incident, min(CHUNK, n_paths - start), rng, resolution, max_order, max_bounces,
                     counts, totals, a_body)
    return counts, totals
