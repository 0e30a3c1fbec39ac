"""RGL measured-BSDF export, spectral (``--format rgl-spectral``).

The same file as :mod:`vcavity.export.rgl` with the colour grid as ``spectra``
``[n_phi, n_theta, n_wavelengths, N, N]`` plus ``wavelengths`` (nm), which Mitsuba 3's
spectral variants and pbrt-v4 (which needs ``jacobian = 1``, as written) read. The BRDF
of a V-cavity table is grey, so every wavelength carries the same value; readers
interpolate linearly between :data:`WAVELENGTHS_NM` and hold the ends beyond them.
"""

from __future__ import annotations

import numpy as np

from vcavity.export import rgl

NAME = "rgl-spectral"
SOURCE = "table"
SUFFIX = ".bsdf"
SUMMARY = "RGL measured BSDF, spectral (Mitsuba 3 spectral variants, pbrt-v4)"
WAVELENGTHS_NM = np.array([360.0, 480.0, 600.0, 720.0, 830.0])


def prepare(table, request):
    """All fields of the spectral file; refuses what :mod:`vcavity.export.rgl` refuses."""
    return rgl.build_fields(table, request, colour_field="spectra", wavelengths=WAVELENGTHS_NM)


write = rgl.write
