"""``--kind slice``: in-plane slices of a table with the single-bounce models of f1.

The plane of incidence (signed theta_o from -90 to 90 deg) across the sensor's cells
(:mod:`vcavity.sensor.plane`), f1, f2 and f_inf by default on a log scale, ±2
standard-error bands, and the V-cavity and Smith models of f1 averaged over the same cells
(:mod:`vcavity.plots.data`). Returns a list of :class:`~vcavity.plots.data.SliceData`, one
per incident direction.
"""

NAME = "slice"
#: What it draws: a table of ``vcavity run`` ("table") or a sweep file ("sweep").
SOURCE = "table"
SCALES = ("log", "linear")
DEFAULT_SCALE = "log"
#: Orders drawn when none are asked for ("all" = every order of the table).
DEFAULT_ORDERS = (1, 2, 0)
#: Models it can overlay on f1 (``vcavity compare --model`` names); empty for none.
MODELS = ("vcavity", "smith")


def render(table, request):
    """Draw the slices of a checked request; returns ``(figure, [SliceData, ...])``."""
    # matplotlib and the models (analytic, Numba) load only when a slice is drawn
    from vcavity.plots import data as plot_data
    from vcavity.plots import figures

    models, notes = plot_data.build_models(table, request.models)
    for note in notes:
        plot_data.warn(note)
    result = [plot_data.slice_data(table, j, request.orders, models, notes) for j in request.indices]
    return figures.slice_figure(table, result, scale=request.scale), result
