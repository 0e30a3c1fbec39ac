"""Parameter packing end to end: a strongly anisotropic GGX (alpha_x = 0.1 along +x,
alpha_y = 0.6 along +y).

1. The simulated f1 at theta_i = 60 deg, phi_i = 0 and 90 deg against the independent
   reference (tests/reference/single_bounce.py), which takes ``alpha_x`` along x by
   construction (its ``D`` is written from H eq. 85 with ``tan²θ cos²φ = m_x²/m_z²``).
   The two azimuths have very different f1 albedos (reference: 0.77873 at phi_i = 0,
   0.90656 at 90 deg), so a swap of alpha_x/alpha_y anywhere exchanges them (z ~ 100).
   Mirror facets (default) and IL facets (slow).

2. A hand-derived expectation, independent of the reference's ``D``: at normal
   incidence on mirror facets the f1 exit is ``o = 2 m_z m - z``, so ``|o_y| > |o_x|``
   exactly when ``|m_y| > |m_x|``, and a groove of normal m gives an f1 exit with
   probability ``G2 = min(1, 2 cos 2θ_m)`` (V-cavity masking at ``i = n``: ``G1(i) = 1``,
   ``G1(o) = 2 m_z o_z/(o.m) = 2 cos 2θ_m``). With stretched slopes
   ``(alpha_x r cos ψ, alpha_y r sin ψ)``, ``ψ`` uniform and ``r`` of density
   ``2r/(1 + r²)²`` (GGX at unit roughness, H sec. 5), the share of f1 exits with
   ``|o_y| > |o_x|`` is ``S = E[G2 [alpha_y |sin ψ| > alpha_x |cos ψ|]] / E[G2]``:
   ``S = 0.868083`` by nested ``scipy.integrate.quad`` below (0.895 without masking,
   ``1 - (2/π) atan(1/6)``), so the lobe is much wider along y. Cell counts cannot
   classify the diagonal cells (crossed by ``|u| = |v|``), hence two exact bounds: the
   f1 exits in cells wholly inside the y-wedges are at least ``S - D`` of all f1 exits
   (``D`` the share in diagonal cells, measured), those in the x-wedges at most
   ``1 - S``. A swapped package gives about 0.06 and 0.74 instead.

False positives: part 1 Sidak over 2 x 2 default tests at a family-wise 1 %; part 2
one-sided 4-sigma bounds (3e-5 each).
"""

import math
import sys
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy import integrate  # noqa: E402

from tests.reference import materials as ref_mat  # noqa: E402
from tests.reference import sensor as ref_sensor  # noqa: E402
from tests.reference import single_bounce as ref_sb  # noqa: E402
from tests.validation._reference_runs import assert_pass, incident, order_counts, run, sidak_threshold, verdicts  # noqa: E402

AX, AY = 0.1, 0.6
MIRROR = {"distribution": "ggx", "alpha_x": AX, "alpha_y": AY, "facet": "mirror"}
IL = {"distribution": "ggx", "alpha_x": AX, "alpha_y": AY, "kd": 0.6, "eta": 1.5}
LEVEL = sidak_threshold(0.01, 4)
PATHS = 1_000_000
RESOLUTION = 11


@pytest.mark.parametrize("phi_deg", [0.0, 90.0])
def test_anisotropic_ggx_f1_against_reference(phi_deg):
    result = run(MIRROR, 60.0, phi_deg, PATHS, RESOLUTION, seed=5101, max_order=1)
    p = ref_sb.f1_cells(ref_mat.parse_material(MIRROR), incident(60.0, phi_deg), RESOLUTION)
    chi, z = verdicts(order_counts(result, 1), p, PATHS)
    assert_pass(chi, z, LEVEL, f"ggx {AX} x {AY} mirror, phi_i = {phi_deg}")


@pytest.mark.slow
@pytest.mark.parametrize("phi_deg", [0.0, 45.0, 90.0])
def test_anisotropic_ggx_il_f1_against_reference(phi_deg):
    result = run(IL, 45.0, phi_deg, 4_000_000, 15, seed=5102, max_order=1)
    p = ref_sb.f1_cells(ref_mat.parse_material(IL), incident(45.0, phi_deg), 15)
    chi, z = verdicts(order_counts(result, 1), p, 4_000_000)
    assert_pass(chi, z, sidak_threshold(0.01, 6), f"ggx {AX} x {AY} IL, phi_i = {phi_deg}")


def hand_share_y_dominant(ax=AX, ay=AY):
    """``S`` of the module docstring, by nested ``quad`` over the stretched-slope construction.

    For fixed ``ψ``, ``tan θ_m = r alpha_o``, ``alpha_o² = ax² cos²ψ + ay² sin²ψ``; ``G2 = 1``
    below ``tan²θ_m = 1/3``, ``2 (1 - tan²)/(1 + tan²)`` up to ``tan θ_m = 1`` and 0 beyond
    (the break points given to quad). Also returns ``E[G2]``, the f1 albedo at normal
    incidence (0.778876, which the reference's cells reproduce to 1e-6).
    """
    density = lambda r: 2.0 * r / (1.0 + r * r) ** 2

    def inner(psi):
        ao = math.sqrt(ax * ax * math.cos(psi) ** 2 + ay * ay * math.sin(psi) ** 2)
        r1, r2 = 1.0 / (math.sqrt(3.0) * ao), 1.0 / ao
        full = integrate.quad(density, 0.0, r1, epsabs=1e-14)[0]
        part = integrate.quad(lambda r: density(r) * 2.0 * (1.0 - (r * ao) ** 2) / (1.0 + (r * ao) ** 2),
                              r1, r2, epsabs=1e-14)[0]
        return full + part

    psi_c = math.atan(ax / ay)  # |m_y| > |m_x|  <=>  |tan psi| > ax/ay; psi in [0, pi/2] by symmetry
    y_part = integrate.quad(inner, psi_c, 0.5 * math.pi, epsabs=1e-13)[0]
    x_part = integrate.quad(inner, 0.0, psi_c, epsabs=1e-13)[0]
    return y_part / (y_part + x_part), (y_part + x_part) / (0.5 * math.pi)


def test_hand_share_is_the_number_in_the_docstring():
    share, albedo = hand_share_y_dominant()
    assert share == pytest.approx(0.868083, abs=1e-6)
    assert hand_share_y_dominant(AY, AX)[0] == pytest.approx(1.0 - 0.868083, abs=1e-6)
    # the reference's D (other construction) gives the same f1 albedo at normal incidence
    p = ref_sb.f1_cells(ref_mat.parse_material(MIRROR), incident(0.0, 0.0), RESOLUTION)
    assert p.sum() == pytest.approx(albedo, rel=1e-5)


def test_f1_lobe_is_wider_along_y():
    n = RESOLUTION
    result = run(MIRROR, 0.0, 0.0, PATHS, n, seed=5103, max_order=1)
    counts = order_counts(result, 1).astype(np.float64)
    u0, u1, v0, v1 = ref_sensor.cell_bounds(n)
    ix, iy = np.arange(n * n) % n, np.arange(n * n) // n
    diagonal = (ix == iy) | (ix + iy == n - 1)
    y_cells = ~diagonal & (np.minimum(abs(v0), abs(v1)) >= np.maximum(abs(u0), abs(u1)))
    x_cells = ~diagonal & ~y_cells
    total = counts.sum()
    s = hand_share_y_dominant()[0]
    d = counts[diagonal].sum() / total
    y_share = counts[y_cells].sum() / total
    x_share = counts[x_cells].sum() / total
    sigma = lambda p: math.sqrt(p * (1.0 - p) / total)
    assert y_share >= s - d - 4.0 * sigma(s - d), (y_share, s, d)
    assert x_share <= (1.0 - s) + 4.0 * sigma(1.0 - s), (x_share, s)
    # second moments from cell centres: the lobe is wider along y by far
    centres = ref_sensor.square_to_direction((2 * ix + 1 - n) / n, (2 * iy + 1 - n) / n)
    mxx = np.sum(counts * centres[:, 0] ** 2) / total
    myy = np.sum(counts * centres[:, 1] ** 2) / total
    assert myy > 3.0 * mxx, (mxx, myy)
