"""Quick-look animation of a snapshot video store: an RGB rendering beside one band.

Each frame is read back from the store (:func:`~sassi_bench.snapshot.video_store.read_frame`)
at a reduced size (every ``step``-th SLM pixel of the factored form, so no full dense cube
is built), rendered as sRGB (:func:`~sassi_bench.calibrate.guide_render.render_rgb`) and,
beside it, the band nearest ``band_nm`` in grey; one brightness scale for the whole video
(the 99.5th percentile of the first frame), so frames can be compared. A strip above the
panels names each one and the frame's number. Written as a GIF by imageio.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from sassi_bench.calibrate.guide_render import render_rgb
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.video_store import read_frame

__all__ = ["video_animation"]


#: Height of the caption strip above the panels (pixels of the GIF).
CAPTION_PX = 18


def _frame_image(
    cube: Rank1Cube, wavelengths, band: int, scale: float, step: int, caption: tuple[str, str]
):
    small = Rank1Cube(
        np.ascontiguousarray(cube.labels[::step, ::step]),
        np.ascontiguousarray(cube.scale[::step, ::step]),
        cube.spectra,
    )
    rgb = render_rgb(small.dense(), wavelengths)
    grey = np.clip(small.band(band) / scale, 0.0, 1.0)
    image = np.concatenate([rgb, np.repeat(grey[..., None], 3, axis=2)], axis=1)
    panels = (255 * np.clip(image, 0.0, 1.0)).astype(np.uint8)
    return np.concatenate([_caption_strip(panels.shape[1], caption), panels], axis=0)


def _caption_strip(width: int, caption: tuple[str, str]) -> np.ndarray:
    """A black strip with each panel's caption at the left of its half, in white."""
    import cv2

    strip = np.zeros((CAPTION_PX, width, 3), dtype=np.uint8)
    for i, text in enumerate(caption):
        origin = (i * (width // 2) + 4, CAPTION_PX - 5)
        cv2.putText(strip, text, origin, cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1,
                    cv2.LINE_AA)  # fmt: skip
    return strip


def video_animation(
    store: str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    band_nm: float = 550.0,
    step: int = 2,
    fps: float = 10.0,
) -> Path:
    """Write the quick-look GIF of a video store (RGB rendering | one band), captioned.

    Parameters
    ----------
    store
        The video store (``video.zarr``).
    path
        The GIF to write.
    band_nm
        The band shown in grey (the nearest bin).
    step
        Every ``step``-th SLM pixel in both directions.
    fps
        Frames per second of the animation.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    Not run here (it needs a procedure's result)::

        video_animation("live/video.zarr", "live/quicklook.gif")
        # PosixPath('live/quicklook.gif')
    """
    import imageio.v2 as imageio

    first, attrs = read_frame(store, 0)
    wavelengths = np.asarray(attrs["wavelength_nm"])
    band = int(np.argmin(np.abs(wavelengths - band_nm)))
    level = float(np.percentile(first.band(band), 99.5))
    scale = level if level > 0 else 1.0
    target = Path(path)
    frames = int(attrs["frames"])
    with imageio.get_writer(target, mode="I", duration=1000.0 / fps, loop=0) as writer:
        for t in range(frames):
            cube, _ = read_frame(store, t)
            caption = (f"sRGB  frame {t + 1}/{frames}", f"{wavelengths[band]:.0f} nm")
            writer.append_data(_frame_image(cube, wavelengths, band, scale, step, caption))
    return target
