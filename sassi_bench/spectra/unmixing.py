"""How stacked pixels' cell sums become their light per bin: the row unmixing's methods.

Pixels stacked in one SLM column overlap on the camera at the blurry ends of the band;
their cell sums are a banded mixture of their light (:mod:`~sassi_bench.spectra.cells`).
:data:`ROW_UNMIXING_METHODS` names the ways to undo it (as colour-science's ``*_METHODS``
tables do), each built once from the bundle's forward model and called on every frame:

* ``"mixed"`` (:class:`MixedUnmixing`, the scans' default): a bin's columns hold light
  of several wavelengths at the red end, each blurred by its own width; those bins are
  unmixed again with each pixel's light there blurred as the mixture of its sources
  (:mod:`~sassi_bench.spectra.row_mixture`). More exact at the red end, about 1.6
  times the assembly's CPU.
* ``"separable"`` (:class:`SeparableUnmixing`): each bin with its own blur alone
  (:func:`~sassi_bench.spectra.cells.unmix_rows`), for scans whose radiometry at the red
  end matters less than their time: the guide registration's rendering to RGB (a third
  of its time, measured: ``docs/notes/2026-12-01-measured-in-code-comments.md``).

Pixels of *different* SLM columns overlapping (dense snapshot masks) are another
problem, fitted on the frame itself (:class:`~sassi_bench.spectra.crosstalk.StreakModel`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.cells import CellLayout, unmix_rows
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.row_mixture import RowMixture, unmix_rows_mixed

__all__ = ["ROW_UNMIXING_METHODS", "MixedUnmixing", "SeparableUnmixing", "row_unmixing"]


class SeparableUnmixing:
    """Each bin's cell sums unmixed with the bin's own blur alone.

    Examples
    --------
    Not run here (it needs measured frames)::

        unmix = SeparableUnmixing(model)
        amplitudes = unmix(sums, layout, geometry)
    """

    def __init__(self, model: StreakForwardModel) -> None:
        self.model = model

    def __call__(
        self, sums: NDArray[np.float64], layout: CellLayout, geometry: StreakGeometry
    ) -> NDArray[np.float64]:
        return unmix_rows(sums, layout, geometry)


class MixedUnmixing:
    """The separable unmixing, then the bins whose sources' blurs differ unmixed again with
    each pixel's light blurred as the mixture of its sources.

    Examples
    --------
    Not run here (it needs measured frames)::

        unmix = MixedUnmixing(model)
        amplitudes = unmix(sums, layout, geometry)
    """

    def __init__(self, model: StreakForwardModel) -> None:
        self.mixture = RowMixture.from_model(model)

    def __call__(
        self, sums: NDArray[np.float64], layout: CellLayout, geometry: StreakGeometry
    ) -> NDArray[np.float64]:
        first = unmix_rows(sums, layout, geometry)
        return unmix_rows_mixed(sums, layout, geometry, self.mixture, first)


#: The row unmixing's methods, by name.
ROW_UNMIXING_METHODS = {"mixed": MixedUnmixing, "separable": SeparableUnmixing}


def row_unmixing(method: str, model: StreakForwardModel) -> SeparableUnmixing | MixedUnmixing:
    """The row unmixing ``method`` (:data:`ROW_UNMIXING_METHODS`) for a forward model.

    Raises
    ------
    ProcedureError
        For an unknown method, naming the known ones.

    Examples
    --------
    >>> row_unmixing("smooth", None)
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: row unmixing: no method 'smooth'. Fix: use one of ...
    """
    if method not in ROW_UNMIXING_METHODS:
        raise ProcedureError(
            step_error(
                "row unmixing",
                f"no method {method!r}",
                f"use one of {', '.join(ROW_UNMIXING_METHODS)}",
            )
        )
    return ROW_UNMIXING_METHODS[method](model)
