"""``--kind albedo``: albedo per order against theta_i, and the inter-reflection share.

The share is ``(f_inf - f1)/f_inf``. Returns :class:`~vcavity.plots.data.AlbedoData`,
restricted to the incident directions asked for.
"""

import numpy as np

NAME = "albedo"
SOURCE = "table"
SCALES = ("linear",)
DEFAULT_SCALE = "linear"
DEFAULT_ORDERS = "all"
MODELS = ()


def render(table, request):
    """Draw the albedo plot of a checked request; returns ``(figure, AlbedoData)``."""
    from vcavity.plots import data as plot_data
    from vcavity.plots import figures  # matplotlib loads only when a plot is drawn

    result = plot_data.albedo_data(table, request.orders)
    if len(request.indices) < len(table.theta_i):
        keep = np.asarray(request.indices)
        result = plot_data.AlbedoData(
            groups=[(phi, members[np.isin(members, keep)]) for phi, members in result.groups
                    if np.isin(members, keep).any()],
            theta_i_deg=result.theta_i_deg, albedo=result.albedo, stderr=result.stderr,
            share=result.share, share_stderr=result.share_stderr)
    return figures.albedo_figure(table, result, request.orders), result
