"""The noise of column sums: photon and read noise of the cells, through the row unmixing.

A column sum (:mod:`~sassi_bench.spectra.cells`) adds camera pixels weighted by the
fraction ``w`` of each column inside the bin, so its variance is
``sum w^2 var(pixel)``: the photon noise of the light *and* the background above the
camera's dark level, ``(sum w^2 / sum w) * level / gain``, plus the read noise of every
pixel of the cell, ``rows * sum w^2 * read^2``. The row unmixing of stacked pixels then
multiplies it by a gain per bin (1 where the cells hold their pixel's light alone, up to
about 5 at the blurriest bins at the scan's 5-row pitch; :func:`row_unmixing_gain`).
Neighbouring bins share the camera column that holds the boundary between them, so their
sums' noise correlates (:meth:`CountsNoise.neighbour_covariance`).

The camera's gain, read noise and dark level come from the rig's *description* (its
``spectral_camera`` section: full well, bit depth, dark offset, read noise), never from a
virtual bench's hidden state. It agrees with a Monte Carlo of the pixels
(``tests/spectra/test_noise.py``) and of the sim rig's frames
(``docs/notes/2026-12-01-measured-in-code-comments.md``).

The variance of every cell is one compiled loop (``_kernels.cell_variance``), and the
scan's reading pass takes a frame's cell sums and their variance in one
(:meth:`CountsNoise.cell_sums`), with no (N, B') temporaries, and the same values to the
bit as the numpy form (``tests/spectra/test_noise.py``; the time it saves:
``docs/notes/2026-12-01-measured-in-code-comments.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.spectra import _kernels
from sassi_bench.spectra.cells import CellLayout
from sassi_bench.spectra.geometry import StreakGeometry

__all__ = ["NEIGHBOUR_REACH", "CountsNoise", "column_weights", "row_unmixing_gain"]

#: Bins past each one whose column sums share a camera column with it (a column can hold
#: three bins where bins are narrower than a column).
NEIGHBOUR_REACH = 2


def column_weights(layout: CellLayout) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``sum w`` and ``sum w^2`` over each cell's columns, (N, B') each.

    ``w`` is the fraction of column ``[c - 0.5, c + 0.5]`` inside the bin, on the camera.

    Examples
    --------
    >>> from sassi_bench.spectra.cells import CellLayout
    >>> layout = CellLayout(*(np.zeros((1, 1)),) * 3, np.zeros((1, 1), int),
    ...                     np.array([[2.25]]), np.array([[3.25]]), (8, 8))
    >>> [a.tolist() for a in column_weights(layout)]  # 0.25 of column 2, 0.75 of column 3
    [[[1.0]], [[0.625]]]
    """
    total, square = np.empty_like(layout.x_left), np.empty_like(layout.x_left)
    _kernels.column_weights(layout.x_left, layout.x_right, float(layout.shape[1]), total, square)
    return total, square


def row_unmixing_gain(
    geometry: StreakGeometry, layout: CellLayout, stack: int = 41
) -> NDArray[np.float64]:
    """The variance gain of the row unmixing per bin, (B',).

    For a long column of pixels stacked at the geometry's median pitch, with the median
    cell and blur of each bin: the squared row of the inverse mixing matrix of the middle pixel
    (a Toeplitz inverse). 1 where no pixels are stacked.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 5]), np.array([3, 3]), np.array([[10.0]] * 2),
    ...                      np.array([[11.0]] * 2), np.array([[4.0], [9.0]]),
    ...                      np.array([3.0]), guard=0)
    >>> from sassi_bench.spectra.cells import cell_layout
    >>> gain = row_unmixing_gain(geo, cell_layout(geo, (20, 30)))
    >>> bool(gain[0] > 1.5)  # a 3 px blur at a 5 px pitch: neighbours' light is undone
    True
    """
    index = layout.index
    upper, lower = index[:, :-1], index[:, 1:]
    paired = (upper >= 0) & (lower >= 0)
    if not paired.any():
        return np.ones(np.shape(geometry.y)[1])
    pitch = np.median(np.abs(geometry.y[lower[paired]] - geometry.y[upper[paired]]), axis=0)
    low = np.median(layout.lo - geometry.y, axis=0)
    high = np.median(layout.hi - geometry.y, axis=0)
    k = np.arange(stack) - stack // 2
    offset = (k[:, None] - k[None, :])[None] * pitch[:, None, None]  # (B', S, S)
    sigma = np.median(geometry.sigma, axis=0)[:, None, None]
    cdf = geometry.profile.cdf
    mixing = cdf((high[:, None, None] + offset) / sigma) - cdf(
        (low[:, None, None] + offset) / sigma
    )
    inverse = np.linalg.inv(mixing)
    return np.sum(inverse[:, stack // 2] ** 2, axis=-1)


@dataclass(frozen=True)
class CountsNoise:
    """The spectral camera's noise: gain, read noise and dark level (camera units).

    Attributes
    ----------
    gain_e_per_adu
        Electrons per ADU (full well over the ADC's range above the dark level).
    read_noise_adu
        Read noise of one pixel.
    dark_offset_adu
        The camera's dark level, part of every raw pixel.
    """

    gain_e_per_adu: float
    read_noise_adu: float
    dark_offset_adu: float

    @classmethod
    def from_camera(cls, camera: Mapping[str, Any]) -> CountsNoise:
        """From a rig description's ``spectral_camera`` section (a mapping).

        Examples
        --------
        >>> noise = CountsNoise.from_camera({"full_well_e": 30000, "bit_depth": 16,
        ...     "dark_offset_adu": 100, "read_noise_e": 3.0})
        >>> round(noise.gain_e_per_adu, 4), round(noise.read_noise_adu, 3)
        (0.4585, 6.543)
        """
        try:
            full_well = float(camera["full_well_e"])
            levels = 2 ** int(camera["bit_depth"]) - 1
            dark = float(camera.get("dark_offset_adu", 0.0))
            read = float(camera["read_noise_e"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(
                step_error(
                    "spectral deblur noise model",
                    f"the spectral camera's description lacks {exc}",
                    "give spectral_camera.full_well_e, bit_depth and read_noise_e in the rig",
                )
            ) from exc
        if not (full_well > 0 and levels > dark and read >= 0):
            raise ConfigError(
                step_error(
                    "spectral deblur noise model",
                    f"full well {full_well:g} e, {levels} levels above a dark level of "
                    f"{dark:g} ADU and read noise {read:g} e are no camera",
                    "fix the rig's spectral_camera section",
                )
            )
        gain = full_well / (levels - dark)
        return cls(gain, read / gain, dark)

    def variance(
        self, raw_sums: NDArray[np.floating], layout: CellLayout, row_gain: NDArray[np.floating]
    ) -> NDArray[np.float64]:
        """Variance of every unmixed column sum, (N, B') in ADU^2.

        Parameters
        ----------
        raw_sums
            (N, B') cell sums of the raw frame (light, background and dark level).
        layout
            The cells (:func:`~sassi_bench.spectra.cells.cell_layout`).
        row_gain
            (B',) :func:`row_unmixing_gain` of the frame's stacking.

        Examples
        --------
        >>> from sassi_bench.spectra.cells import CellLayout
        >>> layout = CellLayout(np.array([[0.5]]), np.array([[4.5]]), np.zeros((1, 1), bool),
        ...                     np.zeros((1, 1), int), np.array([[2.5]]), np.array([[3.5]]),
        ...                     (8, 8))
        >>> noise = CountsNoise(2.0, 1.0, 100.0)
        >>> noise.variance(np.array([[1400.0]]), layout, np.ones(1)).tolist()  # 4 px of 350
        [[504.0]]
        """
        out = np.empty(layout.lo.shape)
        _kernels.cell_variance(
            raw_sums, layout.x_left, layout.x_right, layout.lo, layout.hi,
            float(layout.shape[0]), float(layout.shape[1]), float(self.dark_offset_adu),
            float(self.gain_e_per_adu), float(self.read_noise_adu) ** 2,
            np.ascontiguousarray(row_gain, dtype=np.float64), out,
        )  # fmt: skip
        return out

    def neighbour_covariance(
        self,
        raw_sums: NDArray[np.floating],
        layout: CellLayout,
        row_gain: NDArray[np.floating],
        reach: int = NEIGHBOUR_REACH,
    ) -> NDArray[np.float64]:
        """Covariance of each unmixed column sum with the next ``reach`` bins' of its
        pixel, (N, reach, B') in ADU^2: ``[n, k - 1, b]`` is ``cov(S_b, S_{b+k})``, zero
        where ``b + k`` is past the last bin.

        Neighbouring bins share the camera column that holds the boundary between them
        (``w_b`` of it in one, ``w_{b+k}`` in the other), so the same pixels' noise enters
        both: ``w_b w_{b+k}`` times that column's variance, its photon noise (the signal
        per column taken as :meth:`variance` takes it, uniform across a cell, averaged
        over the two cells) and its read noise over the rows both cells hold, times the
        geometric mean of the two bins' row-unmixing gains. Where bins are narrower than
        a column (the red end of a prism streak) a column can hold three bins, so
        ``reach`` is 2. On the sim rig's ColorChecker scan neighbouring bins' sums
        correlate by 0.25 (0.35 at the red end), which raises the deblurred cube's
        noise by about 20 %.

        Examples
        --------
        >>> from sassi_bench.spectra.cells import CellLayout
        >>> layout = CellLayout(np.array([[0.5, 0.5]]), np.array([[4.5, 4.5]]),
        ...                     np.zeros((1, 2), bool), np.zeros((1, 1), int),
        ...                     np.array([[2.0, 3.25]]), np.array([[3.25, 4.0]]), (8, 8))
        >>> cov = CountsNoise(2.0, 1.0, 100.0).neighbour_covariance(  # 350 ADU a pixel
        ...     np.array([[2250.0, 1350.0]]), layout, np.ones(2))
        >>> cov[0, 0].tolist()  # column 3 shared, 0.75 and 0.25 of it: 0.1875 * (700 + 4)
        [132.0, 0.0]
        """
        raw = np.asarray(raw_sums, dtype=np.float64)
        width = float(layout.shape[1])
        left = np.clip(layout.x_left, -0.5, width - 0.5)
        right = np.clip(layout.x_right, -0.5, width - 0.5)
        total, _ = column_weights(layout)
        top, bottom = layout.top, layout.bottom
        rows = (bottom - top).astype(np.float64)
        above = np.maximum(raw - self.dark_offset_adu * rows * total, 0.0)
        per_row = np.divide(above, total * rows, out=np.zeros_like(above), where=total * rows > 0)
        gain = np.asarray(row_gain, dtype=np.float64)
        out = np.zeros((raw.shape[0], reach, raw.shape[1]))
        for k in range(1, reach + 1):
            a, b = slice(0, -k), slice(k, None)
            column = np.floor(right[:, a] + 0.5)  # the column holding bin b's right end
            shared = column == np.floor(left[:, b] + 0.5)
            w_a = np.minimum(right[:, a], column + 0.5) - np.maximum(left[:, a], column - 0.5)
            w_b = np.minimum(right[:, b], column + 0.5) - np.maximum(left[:, b], column - 0.5)
            overlap = np.where(shared, np.maximum(w_a, 0.0) * np.maximum(w_b, 0.0), 0.0)
            both = np.minimum(bottom[:, a], bottom[:, b]) - np.maximum(top[:, a], top[:, b])
            both = np.maximum(both, 0)
            photons = 0.5 * (per_row[:, a] + per_row[:, b]) * both / self.gain_e_per_adu
            variance = photons + both * float(self.read_noise_adu) ** 2
            out[:, k - 1, a] = overlap * variance * np.sqrt(gain[a] * gain[b])
        return out

    def cell_sums(
        self,
        cumulative: NDArray[np.float64],
        layout: CellLayout,
        row_gain: NDArray[np.floating],
    ) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
        """A raw frame's cell sums, rounded to float32, and their :meth:`variance`, in one
        compiled pass (the scan's reading pass; the same values as
        ``cell_sums(cumulative, layout).astype(np.float32)`` and :meth:`variance` of them).

        Parameters
        ----------
        cumulative
            The raw frame's :func:`~sassi_bench.spectra.cells.column_cumsum`, (H + 1, W).
        layout, row_gain
            As for :meth:`variance`.

        Returns
        -------
        sums, variance
            (N, B') float32 and float64.

        Examples
        --------
        >>> from sassi_bench.spectra.cells import CellLayout, column_cumsum
        >>> layout = CellLayout(np.array([[0.5]]), np.array([[4.5]]), np.zeros((1, 1), bool),
        ...                     np.zeros((1, 1), int), np.array([[2.5]]), np.array([[3.5]]),
        ...                     (8, 8))
        >>> sums, variance = CountsNoise(2.0, 1.0, 100.0).cell_sums(
        ...     column_cumsum(np.full((8, 8), 350.0)), layout, np.ones(1))
        >>> sums.tolist(), variance.tolist()  # column 3, rows 1-4: 4 px of 350
        ([[1400.0]], [[504.0]])
        """
        sums = np.empty(layout.lo.shape, dtype=np.float32)
        variance = np.empty(layout.lo.shape)
        _kernels.cell_sums_variance(
            np.ascontiguousarray(cumulative, dtype=np.float64), layout.x_left, layout.x_right,
            layout.lo, layout.hi, float(self.dark_offset_adu), float(self.gain_e_per_adu),
            float(self.read_noise_adu) ** 2, np.ascontiguousarray(row_gain, dtype=np.float64),
            sums, variance,
        )  # fmt: skip
        return sums, variance
