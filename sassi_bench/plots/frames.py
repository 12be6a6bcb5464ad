"""Raw frames and scanned cubes at a glance."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["cube_figure", "frames_figure"]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def frames_figure(frames: Mapping[str, ArrayLike], columns: int = 3):
    """Camera frames side by side, each scaled to its own 1st-99.9th percentile.

    Parameters
    ----------
    frames
        Title -> frame: arrays or :class:`~sassi_bench.rig.frame.Frame` objects; (H, W, 3)
        frames are shown in colour, (H, W) ones in grey with a colour bar.
    columns
        Frames per row at most.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per frame, in the order of ``frames``.

    Examples
    --------
    >>> fig = frames_figure({"a": np.zeros((4, 4)), "b": np.ones((4, 4, 3))})
    >>> len(fig.axes)
    3
    """
    count = len(frames)
    columns = max(1, min(columns, count))
    rows = -(-count // columns)
    fig = _figure(figsize=(4.2 * columns, 3.4 * rows), layout="constrained")
    for index, (title, frame) in enumerate(frames.items()):
        ax = fig.add_subplot(rows, columns, index + 1)
        image = np.asarray(getattr(frame, "data", frame), dtype=np.float64)
        low, high = np.nanpercentile(image, [1.0, 99.9])
        if image.ndim == 3:  # colour: one scale for all channels
            ax.imshow(np.clip((image - low) / max(high - low, 1e-9), 0.0, 1.0))
        else:
            shown = ax.imshow(image, cmap="gray", vmin=low, vmax=max(high, low + 1e-9))
            fig.colorbar(shown, ax=ax, shrink=0.8, label="ADU")
        ax.set_title(title, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    return fig


def cube_figure(
    cube: ArrayLike,
    wavelengths_nm: ArrayLike,
    pixels: Sequence[tuple[int, int]],
    bands_nm: Sequence[float] = (450.0, 550.0, 650.0),
    units: str = "signal",
):
    """A cube at a few wavelengths, and the spectra of a few (row, col) pixels.

    Parameters
    ----------
    cube
        (H, W, B) cube.
    wavelengths_nm
        (B,) wavelength of each band.
    pixels
        (row, col) of the pixels whose spectra are drawn (and circled on the images).
    bands_nm
        The wavelengths shown as images (the nearest band of each).
    units
        Label of the spectra's axis.

    Returns
    -------
    matplotlib.figure.Figure
        One image per wavelength of ``bands_nm``, then the spectra.

    Examples
    --------
    >>> fig = cube_figure(np.ones((5, 6, 3)), [450, 550, 650], [(1, 2)])
    >>> len(fig.axes) >= 4
    True
    """
    cube = np.asarray(cube)
    wavelengths = np.asarray(wavelengths_nm, dtype=np.float64)
    fig = _figure(figsize=(4.0 * (len(bands_nm) + 1), 3.6), layout="constrained")
    axes = fig.subplots(1, len(bands_nm) + 1)
    for ax, band in zip(axes[:-1], bands_nm, strict=True):
        index = int(np.argmin(np.abs(wavelengths - band)))
        ax.imshow(cube[..., index], cmap="magma")
        ax.set_title(f"{wavelengths[index]:.1f} nm", fontsize=9)
        for number, (row, col) in enumerate(pixels):
            ax.plot(col, row, "o", mfc="none", mec=f"C{number}", ms=8)
        ax.set_xticks([])
        ax.set_yticks([])
    spectra = axes[-1]
    for number, (row, col) in enumerate(pixels):
        spectra.plot(wavelengths, cube[row, col], color=f"C{number}", label=f"({row}, {col})")
    spectra.set_xlabel("wavelength (nm)")
    spectra.set_ylabel(units)
    spectra.legend(fontsize=8)
    return fig
