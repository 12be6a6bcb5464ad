"""Figures as PNG bytes, for bundle reports and notebooks (no display backend needed)."""

from __future__ import annotations

import io

__all__ = ["figure_png"]


def figure_png(fig, dpi: int = 110) -> bytes:
    """Render a matplotlib figure to PNG bytes.

    Parameters
    ----------
    fig
        A :class:`matplotlib.figure.Figure`.
    dpi
        Resolution of the PNG.

    Returns
    -------
    bytes
        The PNG file's bytes.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> figure_png(Figure(figsize=(1, 1)))[:4]
    b'\\x89PNG'
    """
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()
