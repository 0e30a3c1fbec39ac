"""A table as a BRDF for renderers: eval, sample, pdf and albedo_at in plain NumPy (docs/table-api.md)."""

from vcavity.brdf.table_brdf import (
    MAX_PHI_GAP,
    DirectionNotTabulated,
    TableBRDF,
    hemisphere_to_square_array,
    material_is_isotropic,
)

__all__ = ["DirectionNotTabulated", "MAX_PHI_GAP", "TableBRDF", "hemisphere_to_square_array",
           "material_is_isotropic"]
