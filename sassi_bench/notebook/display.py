"""Show figures in a notebook whatever the matplotlib backend (CI runs with Agg)."""

from __future__ import annotations

from sassi_bench.plots.png import figure_png

__all__ = ["show"]


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
