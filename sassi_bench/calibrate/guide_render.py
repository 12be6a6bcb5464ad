"""RGB renderings of spectral cubes for the guide registration, on the SLM grid.

:func:`render_rgb` renders a cube through a camera's spectral sensitivities
(:func:`camera_sensitivities`, colour-science's data sets) or as CIE 1931 -> sRGB;
:func:`rendering_sensitivities` picks between them for a rig's guide sensor;
:func:`upsample_lattice` brings a coarse scan's lattice onto every SLM pixel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.errors import ConfigError, ProcedureError, step_error
from sassi_bench.optics.datasets import camera_sensitivities

__all__ = ["camera_sensitivities", "render_rgb", "rendering_sensitivities", "upsample_lattice"]

# Values of the cube projected at a time (float64: 8 MB).
_PROJECT_VALUES = 1 << 20
STEP = "guide registration"


def rendering_sensitivities(
    sensor: str | None, method: str, wavelengths_nm: ArrayLike
) -> tuple[NDArray[np.float64] | None, str]:
    """The sensitivities :func:`render_rgb` should use, and a label for the bundle.

    Parameters
    ----------
    sensor
        The guide sensor the rig description names (``guide_camera.sensitivities``;
        None when a real rig does not name it).
    method
        ``"camera"`` (the sensor's sensitivities, an error if unknown), ``"cie"``
        (CIE 1931 -> sRGB) or ``"auto"`` (the sensor's when known, else CIE).
    wavelengths_nm
        Bin centres.

    Examples
    --------
    >>> rendering_sensitivities("a lab camera", "auto", [500.0, 600.0])
    (None, 'cie')
    >>> rendering_sensitivities(None, "auto", [500.0, 600.0])
    (None, 'cie')
    >>> rendering_sensitivities("Nikon 5100 (NPL)", "auto", [500.0, 600.0])[1]
    'camera: Nikon 5100 (NPL)'
    """
    if method not in ("auto", "camera", "cie"):
        raise ProcedureError(
            step_error(STEP, f"unknown rendering {method!r}", "use auto, camera or cie")
        )
    if method == "cie" or (sensor is None and method == "auto"):
        return None, "cie"
    if sensor is None:
        raise ConfigError(
            step_error(
                STEP,
                "the rendering is 'camera' but the rig does not name its guide sensor",
                "name it in the rig's guide_camera.sensitivities, or render with 'auto' or 'cie'",
            )
        )
    try:
        return camera_sensitivities(sensor, wavelengths_nm), f"camera: {sensor}"
    except ConfigError:
        if method == "camera":
            raise
        return None, "cie"


def _cie_cmfs(wavelengths_nm: NDArray[np.float64]) -> NDArray[np.float64]:
    import colour

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    values = np.asarray(cmfs.values, dtype=np.float64)
    return np.stack(
        [
            np.interp(wavelengths_nm, cmfs.wavelengths, values[:, c], left=0.0, right=0.0)
            for c in range(3)
        ]
    )


def render_rgb(
    cube: ArrayLike,
    wavelengths_nm: ArrayLike,
    *,
    sensitivities: ArrayLike | None = None,
    valid: ArrayLike | None = None,
    percentile: float = 99.5,
) -> NDArray[np.float32]:
    """Render a spectral cube (per-bin signal) as an RGB image in [0, 1].

    Parameters
    ----------
    cube
        (H, W, B) signal per wavelength bin (already integrated over each bin).
    wavelengths_nm
        (B,) bin centres.
    sensitivities
        (3, B) RGB sensitivities at the bin centres (:func:`camera_sensitivities`): the
        image is what that camera would record, linear. None: CIE 1931 2 degree XYZ
        converted to sRGB (gamma encoded), for rigs whose guide sensor is not known.
    valid
        (H, W) bool, pixels with a measured spectrum; others render black and are left
        out of the normalisation.
    percentile
        The image is scaled so this percentile of the brightest channel is 1 (then clipped).

    Returns
    -------
    ndarray
        (H, W, 3) float32.

    Examples
    --------
    >>> wl = np.linspace(400, 700, 31)
    >>> cube = np.ones((4, 5, 31)) * np.linspace(0, 1, 5)[None, :, None]
    >>> rgb = render_rgb(cube, wl)
    >>> rgb.shape, float(rgb.max()), float(rgb[:, 0].max())
    ((4, 5, 3), 1.0, 0.0)
    """
    data = np.asarray(cube)
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    check_shape(
        data,
        ("H", "W", wl.size),
        step=STEP,
        name="the cube",
        expected_for=f"{wl.size} wavelengths",
        fix="pass an (H, W, B) cube with its B bin centres",
    )
    mask = np.ones(data.shape[:2], bool) if valid is None else np.asarray(valid, bool)
    if sensitivities is not None:
        weights = np.asarray(sensitivities, dtype=np.float64)
        check_shape(
            weights, (3, wl.size), step=STEP, name="sensitivities", fix=f"pass (3, {wl.size})"
        )
        rgb = np.clip(_project(data, mask, weights), 0.0, None)
    else:
        import colour

        xyz = np.clip(_project(data, mask, _cie_cmfs(wl)), 0.0, None)
        peak = _peak(xyz[..., 1], mask, percentile)
        rgb = np.clip(colour.XYZ_to_sRGB(xyz / peak), 0.0, None)
    peak = _peak(rgb.max(axis=-1), mask, percentile)
    return np.clip(rgb / peak, 0.0, 1.0).astype(np.float32)


def _project(
    cube: NDArray, mask: NDArray[np.bool_], weights: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``where(mask & isfinite(cube), cube, 0) @ weights.T`` in float64, a band of rows at
    a time: the same products (each pixel's own), without two float64 copies of the
    whole cube (on a prototype guide cube the copies took most of the render)."""
    out = np.empty((*cube.shape[:2], weights.shape[0]))
    rows = max(1, _PROJECT_VALUES // max(cube.shape[1] * cube.shape[2], 1))
    for start in range(0, cube.shape[0], rows):
        band = np.asarray(cube[start : start + rows], dtype=np.float64)
        keep = mask[start : start + rows, :, None] & np.isfinite(band)
        out[start : start + rows] = np.where(keep, band, 0.0) @ weights.T
    return out


def _peak(plane: NDArray[np.float64], mask: NDArray[np.bool_], percentile: float) -> float:
    values = plane[mask]
    peak = float(np.percentile(values, percentile)) if values.size else 0.0
    return peak if peak > 0 else 1.0


def upsample_lattice(
    image: ArrayLike,
    valid: ArrayLike,
    stride: tuple[int, int],
    slm_shape: tuple[int, int],
    origin: tuple[int, int] = (0, 0),
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Resample an image sampled on a coarse SLM lattice onto every SLM pixel (cubic).

    A coarse scan measures the SLM pixels ``(origin[0] + i * stride[1],
    origin[1] + j * stride[0])`` (row, column). Keys cubic convolution (a = -1/2),
    separable, computed directly (no fixed-point warp tables): pixel centres stay where
    they are and linear ramps are reproduced exactly; each pixel uses its 4 x 4 nearest
    nodes.

    Parameters
    ----------
    image
        (h, w[, C]) values at the lattice nodes.
    valid
        (h, w) bool, nodes with a measurement.
    stride
        (horizontal, vertical) lattice step, SLM px.
    slm_shape
        (H, W) of the output.
    origin
        (row, column) of the first node on the SLM.

    Returns
    -------
    image, valid
        (H, W[, C]) float32, and (H, W) bool: pixels whose every weighted node exists
        and was measured.

    Examples
    --------
    >>> lattice = np.tile(np.arange(6, dtype=np.float32), (2, 1))
    >>> up, ok = upsample_lattice(lattice, np.ones((2, 6), bool), (2, 1), (2, 12))
    >>> up[0, 4:8].round(3).tolist(), ok[0, 9:].tolist()
    ([2.0, 2.5, 3.0, 3.5], [False, True, False])
    """
    sx, sy = int(stride[0]), int(stride[1])
    height, width = int(slm_shape[0]), int(slm_shape[1])
    data = np.asarray(image, dtype=np.float64)
    ok = np.asarray(valid, bool)
    # Lattice coordinates of every SLM pixel centre, one axis at a time (separable).
    rows = (np.arange(height) - float(origin[0])) / sy
    cols = (np.arange(width) - float(origin[1])) / sx
    data, ok = _cubic_axis(data, ok, cols, axis=1)
    data, ok = _cubic_axis(data, ok, rows, axis=0)
    return data.astype(np.float32), ok


def _cubic_axis(data, ok, positions, axis: int):
    """Keys cubic convolution (a = -1/2) along one axis: values, and where every node
    with a non-zero weight exists and is valid."""
    base = np.floor(positions).astype(np.intp)
    t = positions - base
    taps = base[None, :] + np.arange(-1, 3)[:, None]  # (4, P)
    d = np.abs(t[None, :] - np.arange(-1, 3)[:, None])
    weights = np.where(
        d <= 1,
        1.5 * d**3 - 2.5 * d**2 + 1,
        np.where(d < 2, -0.5 * d**3 + 2.5 * d**2 - 4 * d + 2, 0),
    )
    n = data.shape[axis]
    used = np.abs(weights) > 1e-12
    inside = (taps >= 0) & (taps < n)
    index = np.clip(taps, 0, n - 1)
    values = np.take(data, index, axis=axis)  # axis -> (4, P)
    shape = [1] * values.ndim
    shape[axis], shape[axis + 1] = 4, -1
    out = np.sum(values * weights.reshape(shape), axis=axis)
    good = np.take(ok, index, axis=axis) | ~used.reshape(shape[: ok.ndim + 1])
    good &= (inside | ~used).reshape(shape[: ok.ndim + 1])
    return out, good.all(axis=axis)
