"""Reconstructed cubes kept in factored form, materialised as dense cubes only on demand.

A dense float32 cube of the SASSI paper's SLM crop (698 x 931 x 68 bins) is 177 MB: merely
writing one takes longer than the rest of a frame's work. Both reconstructions have an
exact small form:

* :class:`Rank1Cube`: the rank-1 model per region is ``cube[p] = scale[p] * spectra[label[p]]``
  (region labels, a per-pixel scale, one spectrum per region), exact for rank-1;
* :class:`LowRankCube`: the guided filter run in a rank-``K`` spectral basis gives
  ``cube[p] = coefficients[p] @ basis`` (``K`` coefficient images, ``K`` basis spectra).

:meth:`dense` writes the cube (writing, viewing, scoring); :meth:`band` and :meth:`at`
read one band or a few pixels without it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import _kernels

__all__ = ["LowRankCube", "Rank1Cube", "spectral_basis"]


def _output(out: NDArray[np.float32] | None, shape: tuple[int, ...], step: str):
    if out is None:
        return np.empty(shape, np.float32)
    if out.shape != shape or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ProcedureError(
            step_error(
                step,
                f"out has shape {out.shape} and dtype {out.dtype}",
                f"pass a C-contiguous float32 array of shape {shape}",
            )
        )
    return out


@dataclass(frozen=True)
class Rank1Cube:
    """The rank-1 reconstruction in factored form: ``cube[p] = scale[p] * spectra[labels[p]]``.

    Attributes
    ----------
    labels
        (H, W) intp: the region of every SLM pixel.
    scale
        (H, W) float32: every pixel's scale (its guide intensity, or 1 in a region whose
        measured pixels have no guide light).
    spectra
        (R, B) float32: one spectrum per region (per unit of scale).

    Examples
    --------
    >>> cube = Rank1Cube(np.array([[0, 1]]), np.array([[2.0, 1.0]], np.float32),
    ...                  np.array([[1.0, 3.0], [5.0, 7.0]], np.float32))
    >>> cube.dense().tolist(), cube.band(1).tolist()
    ([[[2.0, 6.0], [5.0, 7.0]]], [[6.0, 7.0]])
    """

    labels: NDArray[np.intp]
    scale: NDArray[np.float32]
    spectra: NDArray[np.float32]

    @property
    def shape(self) -> tuple[int, int, int]:
        """The dense cube's (H, W, B)."""
        return (*self.labels.shape, self.spectra.shape[1])

    def dense(self, out: NDArray[np.float32] | None = None) -> NDArray[np.float32]:
        """The (H, W, B) float32 cube, written into ``out`` when given (video: reusing one
        array saves touching fresh memory)."""
        cube = _output(out, self.shape, "snapshot rank-1 cube")
        _kernels.spread_regions(self.spectra, self.labels, self.scale, cube)
        return cube

    def band(self, index: int) -> NDArray[np.float32]:
        """One band, (H, W) float32."""
        return self.spectra[:, index][self.labels] * self.scale

    def at(self, rows: ArrayLike, cols: ArrayLike) -> NDArray[np.float32]:
        """The spectra of pixels ``(rows, cols)``, (N, B) float32."""
        r, c = np.asarray(rows), np.asarray(cols)
        return self.spectra[self.labels[r, c]] * self.scale[r, c][..., None]


@dataclass(frozen=True)
class LowRankCube:
    """A cube in a rank-``K`` spectral basis: ``cube[p] = coefficients[p] @ basis``.

    Attributes
    ----------
    coefficients
        (H, W, K) float32.
    basis
        (K, B) float32: orthonormal basis spectra (rows).

    Examples
    --------
    >>> cube = LowRankCube(np.ones((1, 2, 1), np.float32), np.array([[0.5, 0.25]], np.float32))
    >>> cube.dense().tolist()
    [[[0.5, 0.25], [0.5, 0.25]]]
    """

    coefficients: NDArray[np.float32]
    basis: NDArray[np.float32]

    @property
    def shape(self) -> tuple[int, int, int]:
        """The dense cube's (H, W, B)."""
        return (*self.coefficients.shape[:2], self.basis.shape[1])

    def dense(self, out: NDArray[np.float32] | None = None) -> NDArray[np.float32]:
        """The (H, W, B) float32 cube, written into ``out`` when given."""
        h, w, b = self.shape
        cube = _output(out, (h, w, b), "snapshot low-rank cube")
        flat = self.coefficients.reshape(h * w, -1)
        np.matmul(flat, self.basis, out=cube.reshape(h * w, b))
        return cube

    def band(self, index: int) -> NDArray[np.float32]:
        """One band, (H, W) float32."""
        return self.coefficients @ self.basis[:, index]

    def at(self, rows: ArrayLike, cols: ArrayLike) -> NDArray[np.float32]:
        """The spectra of pixels ``(rows, cols)``, (N, B) float32."""
        return self.coefficients[np.asarray(rows), np.asarray(cols)] @ self.basis


def spectral_basis(spectra: ArrayLike, rank: int) -> NDArray[np.float64]:
    """The ``rank`` leading right singular vectors of ``spectra`` (N, B), as (K, B) rows:
    the orthonormal basis that keeps most of their energy (``K = min(rank, B)``).

    Computed from the (B, B) Gram matrix, so the cost does not grow with the bands' square
    times the pixels twice.

    Examples
    --------
    >>> spectra = np.outer([1.0, 2.0, 3.0], [3.0, 4.0])  # rank 1
    >>> np.abs(spectral_basis(spectra, 1)).round(2).tolist()
    [[0.6, 0.8]]
    """
    values = np.asarray(spectra, dtype=np.float64)
    gram = values.T @ values
    _, vectors = np.linalg.eigh(gram)
    keep = min(int(rank), values.shape[1])
    return np.ascontiguousarray(vectors[:, ::-1][:, :keep].T)
