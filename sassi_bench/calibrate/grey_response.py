"""The SLM's grey-level response, and sinusoids precompensated for it.

An LCoS SLM maps a grey level ``g`` to a transmission through a nonlinear curve (about
``(g / 255) ** 2.2`` on top of the closed-pixel leak ``eps``). Phase shifting needs
sinusoidal *transmission*, so the workbench measures the curve from frames of uniform
patterns (:func:`measure_grey_response`) and inverts it (:func:`sinusoid_profile`).

The response is normalised between the level-0 and level-255 frames, so the leak and
the illumination cancel: ``response(0) == 0`` and ``response(255) == 1``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator
from scipy.stats import trim_mean

from sassi_bench._shared.arrays import check_shape
from sassi_bench.calibrate import _frame_kernels
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["GreyResponse", "harmonic_distortion", "measure_grey_response", "sinusoid_profile"]

_STEP = "grey response"
# Interior points with a normalised response below this are too noisy for the gamma fit.
_GAMMA_FIT_FLOOR = 0.02
# A decrease between neighbouring levels larger than this many standard errors is real.
_MONOTONIC_SIGMAS = 5.0
# Each level's mean leaves out the lowest and highest tenth of the lit pixels' ratios.
_TRIM = 0.1
# The compiled trimmed mean: below this many lit pixels scipy's partition is as quick.
_COMPILED_MIN_PIXELS = 20_000
_COMPILED_DTYPES = (np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))
# Its sample (every 128th ratio) brackets each cut to 6 standard errors of the cut's
# rank: the true cut lies outside with odds near 1e-9, and then the exact fallback runs.
_SAMPLE_STEP = 128
_BAND_SIGMAS = 6.0


def _fit_gamma(levels: NDArray[np.float64], response: NDArray[np.float64]) -> float:
    """Least-squares exponent of ``response ~ (level / 255) ** gamma`` (1 if undetermined)."""
    x = levels / 255.0
    use = (x > 0) & (x < 1) & (response > _GAMMA_FIT_FLOOR) & (response < 1)
    if not np.any(use):
        return 1.0
    lx, ly = np.log(x[use]), np.log(response[use])
    return float(np.clip(np.sum(lx * ly) / np.sum(lx * lx), 0.2, 5.0))


@dataclass(frozen=True, eq=False)
class GreyResponse:
    """Normalised SLM transmission versus grey level, measured at a few levels.

    Between the measured levels the curve is interpolated monotonically (PCHIP) in a
    gamma-linearised space: ``response ** (1 / gamma)`` with ``gamma`` fitted to the
    points, so a power-law SLM is reproduced exactly from a handful of levels and any
    other monotonic curve still passes through every measured point.

    Parameters
    ----------
    levels
        Measured grey levels, strictly increasing, starting at 0 and ending at 255.
    response
        Normalised transmission at ``levels``: non-decreasing, 0 at level 0 and 1 at 255.

    Examples
    --------
    >>> levels = np.array([0, 64, 128, 192, 255])
    >>> r = GreyResponse(levels, (levels / 255.0) ** 2.2)
    >>> round(float(r(100)), 4), int(r.inverse(0.5))
    (0.1275, 186)
    """

    levels: NDArray[np.uint8]
    response: NDArray[np.float64]
    gamma: float = field(init=False, repr=False)
    _linear: PchipInterpolator = field(init=False, repr=False)

    def __post_init__(self) -> None:
        levels = np.asarray(self.levels)
        response = np.asarray(self.response, dtype=np.float64)
        if (
            levels.ndim != 1
            or levels.size < 2
            or not np.issubdtype(levels.dtype, np.integer)
            or levels[0] != 0
            or levels[-1] != 255
            or np.any(np.diff(levels) <= 0)
        ):
            raise ProcedureError(
                step_error(
                    _STEP,
                    f"levels {levels.tolist()} are not strictly increasing integers from 0 to 255",
                    "measure levels 0 and 255 and some in between, each once",
                )
            )
        if response.shape != levels.shape or not np.all(np.isfinite(response)):
            raise ProcedureError(
                step_error(_STEP, "response must be finite, one value per level", "check inputs")
            )
        if np.any(np.diff(response) < 0) or response[0] != 0.0 or response[-1] != 1.0:
            raise ProcedureError(
                step_error(
                    _STEP,
                    "response must be non-decreasing from 0 (level 0) to 1 (level 255)",
                    "build it with measure_grey_response, which normalises and enforces this",
                )
            )
        levels = levels.astype(np.uint8)
        levels.setflags(write=False)
        response = response.copy()
        response.setflags(write=False)
        gamma = _fit_gamma(levels.astype(np.float64), response)
        linear = PchipInterpolator(levels.astype(np.float64), response ** (1.0 / gamma))
        object.__setattr__(self, "levels", levels)
        object.__setattr__(self, "response", response)
        object.__setattr__(self, "gamma", gamma)
        object.__setattr__(self, "_linear", linear)

    @classmethod
    def identity(cls) -> GreyResponse:
        """A linear response, transmission = level / 255.

        Examples
        --------
        >>> float(GreyResponse.identity()(51))
        0.2
        """
        return cls(np.array([0, 255]), np.array([0.0, 1.0]))

    def __call__(self, level: ArrayLike) -> NDArray[np.float64]:
        """Normalised transmission at grey ``level`` (vectorised; clipped to 0..255).

        Examples
        --------
        >>> GreyResponse.identity()(np.array([0, 255])).tolist()
        [0.0, 1.0]
        """
        g = np.clip(np.asarray(level, dtype=np.float64), 0.0, 255.0)
        return np.clip(self._linear(g), 0.0, 1.0) ** self.gamma

    def inverse(self, transmission: ArrayLike) -> NDArray[np.uint8]:
        """The grey level whose transmission is nearest to ``transmission`` (vectorised).

        Examples
        --------
        >>> GreyResponse.identity().inverse([0.0, 0.5, 1.0]).tolist()
        [0, 128, 255]
        """
        table = self(np.arange(256))
        t = np.clip(np.asarray(transmission, dtype=np.float64), 0.0, 1.0)
        upper = np.clip(np.searchsorted(table, t), 1, 255)
        lower = upper - 1
        nearest = np.where(np.abs(table[lower] - t) < np.abs(table[upper] - t), lower, upper)
        return nearest.astype(np.uint8)


def _lit_mask(span: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Pixels the level-255 frame lights to at least half the brightest (99th pct.) signal."""
    top = float(np.percentile(span, 99.0))
    return span >= 0.5 * top if top > 0 else np.zeros(span.shape, dtype=bool)


def _check_inputs(levels: NDArray[np.integer], frames: NDArray, dark: ArrayLike) -> None:
    check_shape(
        frames,
        (levels.size, "H", "W"),
        step=_STEP,
        name="the frame stack",
        expected_for=f"{levels.size} levels",
        fix="pass one (H, W) frame per level, stacked as (levels, H, W)",
    )
    check_shape(
        dark,
        [(), frames.shape[1:]],
        step=_STEP,
        name="dark",
        fix="pass a dark frame of the frames' shape (or a scalar black level)",
    )
    if levels.size < 3 or len(set(levels.tolist())) != levels.size:
        raise ProcedureError(
            step_error(
                _STEP,
                f"levels {levels.tolist()} are too few or repeated",
                "capture at least 3 distinct levels (e.g. every 16 from 0 to 255)",
            )
        )
    if 0 not in levels or 255 not in levels:
        raise ProcedureError(
            step_error(_STEP, "levels 0 and 255 are both needed", "add them to the capture plan")
        )
    if levels.min() < 0 or levels.max() > 255:
        raise ProcedureError(
            step_error(_STEP, "levels must lie in 0..255", "check the capture plan")
        )


def _enforce_monotonic(
    levels: NDArray[np.integer], mean: NDArray[np.float64], stderr: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Reject decreases beyond noise; smooth away the rest (mean of running max and min)."""
    drop = -np.diff(mean)
    allowed = _MONOTONIC_SIGMAS * np.hypot(stderr[:-1], stderr[1:]) + 1e-9
    bad = np.flatnonzero(drop > allowed)
    if bad.size:
        i = int(bad[0])
        raise ProcedureError(
            step_error(
                _STEP,
                f"transmission falls from {mean[i]:.4f} at level {levels[i]} to "
                f"{mean[i + 1]:.4f} at level {levels[i + 1]}, beyond noise",
                "check that the light and exposure were stable and no frame is saturated, "
                "then capture the levels again",
            )
        )
    rising = np.maximum.accumulate(mean)
    falling = np.minimum.accumulate(mean[::-1])[::-1]
    response = np.clip(0.5 * (rising + falling), 0.0, 1.0)
    response[0], response[-1] = 0.0, 1.0
    return response


def measure_grey_response(
    levels: ArrayLike,
    frames: ArrayLike,
    dark: ArrayLike,
    mask: ArrayLike | None = None,
    saturation_level: float | None = 65535,
) -> GreyResponse:
    """Measure the SLM's grey-level response from frames of uniform patterns.

    Every pixel's signal is normalised between its level-0 and level-255 frames (so
    illumination and the closed-pixel leak cancel) and the per-level value is a 10 %
    trimmed mean over the lit pixels.

    Parameters
    ----------
    levels
        Grey level of each frame (any order; must include 0 and 255; at least 3).
    frames
        Camera frames (levels, H, W), uint16 or float, one per uniform pattern.
    dark
        Dark frame (H, W) or scalar black level, subtracted from every frame.
    mask
        Pixels to use (H, W) bool. Default: pixels whose level-255 signal is at least
        half the 99th percentile.
    saturation_level
        Raw value (before dark subtraction) at which the camera saturates; pixels that
        reach it in any frame are left out. ``None`` skips the check.

    Returns
    -------
    GreyResponse

    Raises
    ------
    ValueError
        For mismatched shapes, too few levels, no lit pixels, or a response that
        decreases by more than the noise allows.

    Examples
    --------
    >>> levels = np.array([0, 32, 64, 128, 192, 255])
    >>> frames = 100.0 + 4000.0 * (levels[:, None, None] / 255.0) ** 2.2 * np.ones((6, 4, 4))
    >>> r = measure_grey_response(levels, frames, dark=100.0)
    >>> round(r.gamma, 3), int(r.inverse(0.25))
    (2.2, 136)
    """
    levels = np.asarray(levels)
    frames = np.asarray(frames)
    _check_inputs(levels, frames, dark)
    # One frame at a time in float64: the stack itself (uint16 from a session) is not copied.
    order = np.argsort(levels)
    levels = levels[order].astype(np.int64)
    dark = np.asarray(dark, dtype=np.float64)
    low = frames[order[0]] - dark
    span = (frames[order[-1]] - dark) - low
    use = _lit_mask(span) if mask is None else np.asarray(mask, dtype=bool) & (span > 0)
    if saturation_level is not None and use.shape == span.shape:
        for frame in frames:
            use &= frame < saturation_level
    if use.shape != span.shape or not np.any(use):
        raise ProcedureError(
            step_error(
                _STEP,
                "no usable lit pixels (mask empty or of the wrong shape, level 255 not "
                "brighter than level 0, or every lit pixel saturated)",
                "check the light is on, the exposure and the mask's shape",
            )
        )
    lit = np.flatnonzero(use)
    dark_lit = dark.ravel()[lit] if dark.ndim else dark
    low_lit, span_lit = low.ravel()[lit], span.ravel()[lit]
    mean = np.empty(levels.size)
    stderr = np.empty(levels.size)
    # The lowest and highest levels' ratios are exactly 0 and 1 (``low`` and ``span`` are
    # those frames' own differences) wherever ``low`` is finite.
    ends = bool(np.isfinite(low_lit).all())
    for k, index in enumerate(order):
        if ends and k in (0, levels.size - 1):
            mean[k], spread = float(k > 0), 0.0
        else:
            mean[k], spread = _trimmed_ratio(frames[index], lit, dark_lit, low_lit, span_lit)
        stderr[k] = spread / np.sqrt(lit.size)
    return GreyResponse(levels, _enforce_monotonic(levels, mean, stderr))


def _trimmed_ratio(
    frame: NDArray,
    lit: NDArray[np.intp],
    dark_lit: NDArray[np.float64],
    low_lit: NDArray[np.float64],
    span_lit: NDArray[np.float64],
) -> tuple[float, float]:
    """``trim_mean(ratio, 0.1)`` and ``std(ratio)`` of one frame's lit pixels'
    normalised signal ``ratio = (frame[lit] - dark - low) / span``.

    A compiled pass gives both without sorting the ratios (the same values trimmed;
    the sum in another order, so equal to rounding); small or degenerate sets (too few
    pixels, ties or non-finite values at the cuts) take scipy's partition.
    """
    flat = np.ascontiguousarray(frame).ravel()
    if lit.size >= _COMPILED_MIN_PIXELS and flat.dtype in _COMPILED_DTYPES:
        dark = np.atleast_1d(np.asarray(dark_lit, dtype=np.float64))
        lowercut = int(_TRIM * lit.size)
        mean, spread, ok = _frame_kernels.trimmed_ratio_mean(
            flat, lit, dark, low_lit, span_lit, lowercut, _SAMPLE_STEP, _BAND_SIGMAS
        )
        if ok:
            return float(mean), float(spread)
    ratio = (flat[lit] - dark_lit - low_lit) / span_lit
    return float(trim_mean(ratio, _TRIM)), float(np.std(ratio))


def sinusoid_profile(period: int, response: GreyResponse | None = None) -> NDArray[np.uint8]:
    """Grey levels of one period whose transmission is ``0.5 + 0.5 cos(2 pi j / period)``.

    Parameters
    ----------
    period
        Samples (SLM pixels) per period, at least 3.
    response
        The SLM's measured response; ``None`` assumes a linear SLM (``round(255 t)``).

    Returns
    -------
    ndarray
        uint8 levels (period,), for a ``periodic`` pattern descriptor's ``profile``.

    Examples
    --------
    >>> sinusoid_profile(4).tolist()
    [255, 128, 0, 128]
    """
    if isinstance(period, bool) or not isinstance(period, (int, np.integer)) or period < 3:
        raise ProcedureError(
            step_error("sinusoid profile", f"period {period!r} is not an integer >= 3", "use 16")
        )
    # Rounded so that mirror samples (j, period - j) get the same level despite float noise.
    t = np.round(0.5 + 0.5 * np.cos(2.0 * np.pi * np.arange(period) / period), 12)
    if response is None:
        return np.rint(255.0 * t).astype(np.uint8)
    return response.inverse(t)


def harmonic_distortion(transmission: ArrayLike) -> float:
    """Total harmonic distortion of one sampled period: harmonics' RMS over the fundamental.

    Examples
    --------
    >>> j = np.arange(16)
    >>> round(harmonic_distortion(0.5 + 0.5 * np.cos(2 * np.pi * j / 16)), 12)
    0.0
    """
    samples = np.asarray(transmission, dtype=np.float64)
    spectrum = np.abs(np.fft.rfft(samples))
    if samples.size % 2 == 0:
        spectrum[-1] *= 0.5  # the Nyquist bin holds its harmonic once, not twice
    if spectrum.size < 3 or spectrum[1] == 0:
        raise ProcedureError(
            step_error(
                "harmonic distortion",
                "need at least 4 samples of one period with a non-zero fundamental",
                "pass one full period of the transmission",
            )
        )
    return float(np.sqrt(np.sum(spectrum[2:] ** 2)) / spectrum[1])
