"""Show figures in a notebook whatever the matplotlib backend (CI runs with Agg)."""

from __future__ import annotations

from sassi_bench.plots.png import figure_png

__all__ = ["say_clipping", "show"]


def show(figure) -> None:
    """Display a matplotlib figure, or PNG bytes, as a PNG output of the current cell.

    Examples
    --------
    Not run here (it needs a notebook)::

        from matplotlib.figure import Figure
        show(Figure(figsize=(1, 1)))
    """
    from IPython.display import Image, display

    png = figure if isinstance(figure, bytes) else figure_png(figure)
    display(Image(data=png, format="png"))


def say_clipping(views, rig) -> None:
    """Print how much of each shown frame is saturated or clipped at zero, with advice
    (:func:`sassi_bench.acquire.saturation.clipping_of_views`); a frame clipped beyond a
    trace is marked with a warning sign.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        say_clipping(capture_views(rig), rig)
        # ⚠ spectral all open: 63.0 % of pixels at full scale (4095 ADU), 0.0 % at zero. ...
    """
    from sassi_bench.acquire.saturation import clipping_of_views

    for found in clipping_of_views(views, rig):
        print(("" if found.ok else "\u26a0 ") + found.describe())
