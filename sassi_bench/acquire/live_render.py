"""A live frame as a person looks at it: 8-bit, clipped pixels in colour, a histogram.

The frame is scaled linearly to the sensor's full scale (a dim frame looks dim: that is
the exposure a person judges), and the pixels that lost their value are painted over:
pixels at full scale in :data:`SATURATED_RGB`, pixels at zero in :data:`ZERO_RGB`, so
the share :func:`~sassi_bench.acquire.saturation.clipping` states is the share of those
colours in the image. The image keeps the camera's size (one image pixel per sensor
pixel).

Examples
--------
>>> frame = np.array([[0, 100], [4095, 4095]], np.uint16)
>>> image = overlay_rgb(frame, bit_depth=12)
>>> image[1, 0].tolist(), image[0, 0].tolist()
([255, 0, 0], [0, 0, 255])
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["SATURATED_RGB", "ZERO_RGB", "encode_png", "histogram", "overlay_rgb"]

#: The colour of saturated pixels (a colour pixel is saturated when any channel is).
SATURATED_RGB = (255, 0, 0)
#: The colour of pixels at zero (all channels).
ZERO_RGB = (0, 0, 255)


def overlay_rgb(frame: NDArray[Any], *, bit_depth: int) -> NDArray[np.uint8]:
    """The frame as (H, W, 3) 8-bit RGB with its clipped pixels painted over.

    Parameters
    ----------
    frame
        (H, W) monochrome or (H, W, 3) colour pixel values.
    bit_depth
        The sensor's bits per value.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) uint8.

    Examples
    --------
    >>> overlay_rgb(np.full((2, 3), 2048, np.uint16), bit_depth=12)[0, 0].tolist()
    [127, 127, 127]
    """
    data = np.asarray(frame)
    full_scale = (1 << int(bit_depth)) - 1
    scaled = (data.astype(np.float32) * (255.0 / full_scale)).clip(0, 255).astype(np.uint8)
    image = np.repeat(scaled[..., None], 3, axis=-1) if data.ndim == 2 else scaled[..., :3]
    image = np.ascontiguousarray(image)
    at_top = data >= full_scale
    at_zero = data <= 0
    if data.ndim == 3:
        at_top, at_zero = at_top.any(axis=-1), at_zero.all(axis=-1)
    image[at_zero] = ZERO_RGB
    image[at_top] = SATURATED_RGB
    return image


def encode_png(image: NDArray[np.uint8]) -> bytes:
    """PNG bytes of an (H, W, 3) RGB image, compressed lightly (speed over size: the
    image crosses the loopback interface only).

    Examples
    --------
    >>> encode_png(np.zeros((2, 2, 3), np.uint8))[:4]
    b'\\x89PNG'
    """
    ok, buffer = cv2.imencode(".png", image[..., ::-1], [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise ValueError(f"live view: the frame {image.shape} could not be encoded as PNG")
    return buffer.tobytes()


def histogram(frame: NDArray[Any], *, bit_depth: int, bins: int = 64) -> list[int]:
    """Pixel counts in ``bins`` equal bins from zero to full scale (every channel).

    Examples
    --------
    >>> histogram(np.array([0, 1, 254, 255], np.uint8), bit_depth=8, bins=2)
    [2, 2]
    """
    full_scale = (1 << int(bit_depth)) - 1
    values = np.asarray(frame).ravel()
    index = np.minimum(values.astype(np.int64) * bins // (full_scale + 1), bins - 1)
    return np.bincount(index, minlength=bins).tolist()
