"""Blender Cycles' ``table_ggx_E`` (32 x 32) and ``table_ggx_Eavg`` (32), quoted as shipped.

The data file ``tests/reference/data/cycles_ggx_E.tables`` is an excerpt of
``intern/cycles/scene/shader.tables`` of blender/blender at commit :data:`COMMIT` (its
licence header and the two arrays, unchanged; computed by
``intern/cycles/app/cycles_precompute.cpp``). This module only parses the C text: it
computes nothing from it.

Cycles' layout: ``data[y * 32 + x]``, ``x`` the roughness node ``r = sqrt(alpha) =
clamp(x/31, 1e-4, 1)``, ``y`` the ``mu = cos(theta_i) = clamp(y/31, 1e-4, 1)`` node;
``E_avg[x] = integral 2 mu E dmu`` (Monte Carlo over continuous ``mu``). Values carry 6
decimals. ``E`` is the single-scattering albedo of GGX with white (F = 1) mirror facets,
the height-correlated Smith ``G2`` and the exact GGX ``Lambda``, estimated with 2^23
Sobol samples per node (``E_avg``: 2^26).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data" / "cycles_ggx_E.tables"
REPOSITORY = "blender/blender"
FILE = "intern/cycles/scene/shader.tables"
COMMIT = "09cf4924cc65e989ffde4965b87302c0ec431c96"
SOURCE = f"{REPOSITORY} {FILE} at {COMMIT[:12]}"
N = 32


def _array(text: str, name: str) -> np.ndarray:
    """The ``static const float name[n] = {...};`` of ``text`` as float64 (the printed decimals)."""
    match = re.search(r"static const float " + re.escape(name) + r"\[(\d+)\] = \{(.*?)\};", text, re.S)
    if match is None:
        raise ValueError(f"{DATA}: no array {name}")
    values = [float(item.strip().removesuffix("f")) for item in match.group(2).split(",") if item.strip()]
    if len(values) != int(match.group(1)):
        raise ValueError(f"{DATA}: {name} has {len(values)} values, declared {match.group(1)}")
    return np.array(values, dtype=np.float64)


def load(path: Path = DATA) -> tuple[np.ndarray, np.ndarray]:
    """``(E, E_avg)``: ``E[y, x]`` (so ``E.ravel()`` is Cycles' ``data[y * 32 + x]``) and
    ``E_avg[x]``, float64 holding the shipped decimals.

    Parameters
    ----------
    path : pathlib.Path, optional
        The excerpt (default: :data:`DATA`).
    """
    text = Path(path).read_text()
    return _array(text, "table_ggx_E").reshape(N, N), _array(text, "table_ggx_Eavg")


def nodes() -> np.ndarray:
    """Cycles' node values ``clamp(i / 31, 1e-4, 1)`` (``r`` and ``mu`` alike), from
    ``cycles_precompute.cpp``'s rule, written here independently of vcavity."""
    return np.clip(np.arange(N) / (N - 1), 1e-4, 1.0)
