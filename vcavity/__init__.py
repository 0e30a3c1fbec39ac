"""vcavity: Monte-Carlo simulation of light inside microfacet V-cavities.

Public entry points
-------------------
open_table(path)
    Read a BRDF table written by ``vcavity run`` (HDF5 format v2, or v1); imports no
    Numba and compiles nothing.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("vcavity")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"


def open_table(path):
    """Open a vcavity HDF5 table; see :func:`vcavity.io.table.open_table`."""
    from vcavity.io.table import open_table as _open_table

    return _open_table(path)


__all__ = ["__version__", "open_table"]
