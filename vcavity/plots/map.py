"""``--kind map``: equal-area hemispherical maps of each order, one row per incident direction.

Returns ``{(incidence index, order): (N, N) values}``.
"""

NAME = "map"
SOURCE = "table"
SCALES = ("log", "linear")
DEFAULT_SCALE = "linear"
DEFAULT_ORDERS = "all"
MODELS = ()


def render(table, request):
    """Draw the maps of a checked request; returns ``(figure, {(index, order): values})``."""
    from vcavity.plots import figures  # matplotlib loads only when a plot is drawn

    return figures.map_figure(table, request.indices, request.orders, scale=request.scale)
