"""Tables against analytic models: f1 against the single-bounce models, and any order of a
specular table against the every-order model (``vcavity compare``)."""

from vcavity.compare.orders import OrderComparison, OrdersReport, compare_order, format_order_report
from vcavity.compare.single_bounce import (
    DEFAULT_SIGNIFICANCE,
    MODELS,
    ComparisonReport,
    PlotsNotWritten,
    DirectionComparison,
    build_model,
    compare_table,
    format_report,
    material_of_table,
)

__all__ = ["compare_table", "format_report", "material_of_table", "build_model", "MODELS", "DEFAULT_SIGNIFICANCE",
           "ComparisonReport", "DirectionComparison", "compare_order", "format_order_report", "OrdersReport",
           "OrderComparison", "PlotsNotWritten"]
