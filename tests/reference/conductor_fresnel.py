"""Reference Fresnel reflectance of a conductor, written from the textbook in NumPy complex
arithmetic (Born & Wolf, Principles of Optics, ch. 14; the same form as pbrt-v4's
``FrComplex``): Snell's law with a complex index, ``cos_t = sqrt(1 - sin^2/n^2)``, then

    r_s = (cos_i - n cos_t)/(cos_i + n cos_t),   r_p = (n cos_i - cos_t)/(n cos_i + cos_t),
    F = (|r_s|^2 + |r_p|^2)/2.

Nothing of vcavity is used. It is evaluated in ``np.clongdouble`` (80-bit extended
precision on x86-64 Linux, eps 1.1e-19), so that the differences of nearly equal terms
that this direct form contains (``cos_i - n cos_t`` for ``n`` near 1) still leave it
about 1e-16 relative accuracy on the test grids; where ``np.longdouble`` is plain double
:data:`EXTENDED` is False and the tests that need it skip.
"""

from __future__ import annotations

import numpy as np

#: True when np.longdouble carries more precision than float64 (the reference needs it).
EXTENDED = np.finfo(np.longdouble).eps < 1e-18


def fresnel_conductor(cos_i, eta, k):
    """F of a conductor of relative index ``eta + i k`` at cosines ``cos_i`` in [0, 1] (float64)."""
    c = np.asarray(cos_i, dtype=np.longdouble)
    n = np.longdouble(eta) + np.longdouble(k) * np.clongdouble(1j)
    sin2_i = 1 - c * c
    cos_t = np.sqrt(1 - sin2_i / (n * n))
    r_s = (c - n * cos_t) / (c + n * cos_t)
    r_p = (n * c - cos_t) / (n * c + cos_t)
    return ((np.abs(r_s) ** 2 + np.abs(r_p) ** 2) / 2).astype(np.float64)
