"""vcavity: Monte-Carlo simulation of light inside microfacet V-cavities.

Public entry points
-------------------
open_table(path)
    Read a BRDF table written by ``vcavity run`` (HDF5 format v3, v2 or v1); imports no
    Numba and compiles nothing. The table it returns is also a BRDF for renderers:
    ``t.eval(wi, wo, order)``, ``t.sample(wi, u1, u2, order)``, ``t.pdf(wi, wo, order)``,
    ``t.albedo_at(wi, order)`` (docs/table-api.md).
TableBRDF, DirectionNotTabulated
    That renderer view (:mod:`vcavity.brdf.table_brdf`, plain NumPy) and its error for incident
    azimuths an anisotropic table does not cover.
"""

from vcavity._version import __version__


def open_table(path):
    """Open a vcavity HDF5 table; see :func:`vcavity.io.table.open_table`."""
    from vcavity.io.table import open_table as _open_table

    return _open_table(path)


def __getattr__(name):
    # Lazy, like open_table: `import vcavity` stays free of h5py and of the table API.
    if name in ("TableBRDF", "DirectionNotTabulated"):
        from vcavity.brdf import table_brdf as brdf

        return getattr(brdf, name)
    raise AttributeError(f"module 'vcavity' has no attribute {name!r}")


__all__ = ["DirectionNotTabulated", "TableBRDF", "__version__", "open_table"]
