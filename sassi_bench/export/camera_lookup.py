"""The inverse of a bundle's dispersion map: which SLM position each camera pixel sees.

At one wavelength the bundle's map ``(u, v) -> (x, y)`` (:meth:`CalibrationBundle.
slm_to_camera`) is smooth and one to one, so every camera pixel inside the image of the
SLM has exactly one SLM position (sub-pixel) whose light of that wavelength lands on its
centre. :func:`solve_camera_lookup` finds it by Newton's method (Jacobian by central
differences of the bundle's map) on a coarse grid of camera nodes, starting from the
inverse of an affine fit per band; :meth:`CameraLookup.band` interpolates the nodes
bilinearly to every camera pixel. The inverse is smooth (relay distortion and field-
dependent dispersion bend it by a few pixels over the whole field), so interpolation
error falls with the square of the node step, and at the default 8 px it is far under the
calibration's own error (``docs/notes/2026-12-01-measured-in-code-comments.md``). The
full-resolution tables are produced one band at a time, so they
never all exist in memory at once.

Where several SLM pixels fall into one camera pixel (relay magnification below 1), the
lookup gives the position under the camera pixel's *centre*; rounding it gives the SLM
pixel whose area contains that point. A camera pixel whose centre sees no part of the
SLM (its preimage lies outside ``-0.5 .. W - 0.5`` by ``-0.5 .. H - 0.5``) is unreached
(NaN here; exporters choose what to write).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["CameraLookup", "solve_camera_lookup"]

#: Step (SLM px) of the central differences that give the map's Jacobian.
_DIFF_STEP = 0.5
#: Newton stops when every node lands within this distance (camera px) of its target.
_TOLERANCE_PX = 1e-6
_MAX_ITERATIONS = 12


@dataclass(frozen=True)
class CameraLookup:
    """SLM position seen by camera nodes every ``step`` px, per wavelength band.

    Attributes
    ----------
    wavelengths
        Band wavelengths in nm, ``(T,)``.
    camera_shape
        Camera ``(H, W)``.
    slm_shape
        SLM ``(H, W)``.
    step
        Node spacing in camera px; nodes sit at ``x = 0, step, 2 step, ...`` up to the
        first one at or beyond the last column (likewise rows).
    u, v
        SLM column and row at each node, ``(T, rows, cols)`` float64; NaN where the node
        lies too far outside the SLM's image to be solved.
    """

    wavelengths: NDArray[np.float64]
    camera_shape: tuple[int, int]
    slm_shape: tuple[int, int]
    step: int
    u: NDArray[np.float64]
    v: NDArray[np.float64]

    def band(self, index: int) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """SLM ``(u, v)`` seen by every camera pixel in band ``index``, ``(H, W)`` float32
        each; NaN where the pixel is unreached.

        Examples
        --------
        >>> lookup = solve_camera_lookup(bundle, (512, 800))
        >>> u, v = lookup.band(0)
        >>> u.shape == lookup.camera_shape
        True
        """
        height, width = self.camera_shape
        rows = _interpolate_axis(self.u[index], height, self.step, axis=0)
        u = _interpolate_axis(rows, width, self.step, axis=1)
        rows = _interpolate_axis(self.v[index], height, self.step, axis=0)
        v = _interpolate_axis(rows, width, self.step, axis=1)
        slm_h, slm_w = self.slm_shape
        outside = ~((u >= -0.5) & (u <= slm_w - 0.5) & (v >= -0.5) & (v <= slm_h - 0.5))
        u[outside] = np.nan
        v[outside] = np.nan
        return u, v

    def bands(self) -> Iterator[tuple[NDArray[np.float32], NDArray[np.float32]]]:
        """:meth:`band` for every band in order."""
        for index in range(self.wavelengths.size):
            yield self.band(index)


def _interpolate_axis(nodes: NDArray, length: int, step: int, axis: int) -> NDArray[np.float32]:
    """Linear interpolation along ``axis`` from nodes every ``step`` px to ``length`` px
    (NaN nodes give NaN wherever they take part)."""
    position = np.arange(length) / step
    left = np.minimum(position.astype(np.intp), nodes.shape[axis] - 2)
    weight = (position - left).astype(np.float32)
    a = np.take(nodes, left, axis=axis).astype(np.float32)
    b = np.take(nodes, left + 1, axis=axis).astype(np.float32)
    shape = [1, 1]
    shape[axis] = length
    weight = weight.reshape(shape)
    return a + weight * (b - a)


def _affine_inverse(
    bundle: CalibrationBundle, wavelengths: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per band, the matrix ``M (T, 2, 2)`` and offset ``c (T, 2)`` of the inverse of the
    least-squares affine fit of the map: ``(u, v) ~ M (x, y) + c``."""
    height, width = bundle.slm_shape
    gv, gu = np.meshgrid(np.linspace(0, height - 1, 17), np.linspace(0, width - 1, 17))
    u, v = gu.ravel(), gv.ravel()
    x, y = bundle.slm_to_camera(u[:, None], v[:, None], wavelengths[None, :])  # (P, T)
    out_m = np.empty((wavelengths.size, 2, 2))
    out_c = np.empty((wavelengths.size, 2))
    for t in range(wavelengths.size):  # one small least-squares fit per band
        points = np.column_stack([x[:, t], y[:, t], np.ones_like(u)])
        coeffs, *_ = np.linalg.lstsq(points, np.column_stack([u, v]), rcond=None)
        out_m[t] = coeffs[:2].T
        out_c[t] = coeffs[2]
    return out_m, out_c


def _newton(
    bundle: CalibrationBundle,
    wavelength: float,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Solve ``slm_to_camera(u, v, wavelength) = (x, y)`` from the start ``(u, v)``;
    nodes that do not converge become NaN.

    The Jacobian is taken once, at the start (central differences), and kept: the map is
    so nearly affine over a step that this chord iteration gains about six digits per
    step, at a fifth of the cost of a fresh Jacobian each time.
    """
    h = _DIFF_STEP
    fx, fy = bundle.slm_to_camera(
        u + np.array([h, -h, 0.0, 0.0])[:, None], v + np.array([0.0, 0.0, h, -h])[:, None],
        wavelength,
    )  # fmt: skip
    jxu, jyu = (fx[0] - fx[1]) / (2 * h), (fy[0] - fy[1]) / (2 * h)
    jxv, jyv = (fx[2] - fx[3]) / (2 * h), (fy[2] - fy[3]) / (2 * h)
    with np.errstate(divide="ignore", invalid="ignore"):
        det = jxu * jyv - jxv * jyu
        inv = np.stack([jyv / det, -jxv / det, -jyu / det, jxu / det])
    active = np.all(np.isfinite(inv), axis=0)
    for _ in range(_MAX_ITERATIONS):
        if not active.any():
            break
        ua, va = u[active], v[active]
        fx, fy = bundle.slm_to_camera(ua, va, wavelength)
        rx, ry = fx - x[active], fy - y[active]
        i00, i01, i10, i11 = inv[:, active]
        u[active] = ua - (i00 * rx + i01 * ry)
        v[active] = va - (i10 * rx + i11 * ry)
        settled = (np.maximum(np.abs(rx), np.abs(ry)) < _TOLERANCE_PX) | ~np.isfinite(rx + ry)
        active[np.flatnonzero(active)[settled]] = False
    # Nodes far outside the SLM, where the polynomial extrapolates badly, may not settle.
    fx, fy = bundle.slm_to_camera(u, v, wavelength)
    failed = ~(np.maximum(np.abs(fx - x), np.abs(fy - y)) < 1e-3)
    u[failed] = np.nan
    v[failed] = np.nan
    return u, v


def solve_camera_lookup(
    bundle: CalibrationBundle,
    camera_shape: tuple[int, int],
    wavelengths: ArrayLike | None = None,
    *,
    step: int = 8,
) -> CameraLookup:
    """Invert the bundle's dispersion map on a grid of camera nodes, band by band.

    Parameters
    ----------
    bundle
        The calibration bundle.
    camera_shape
        Spectral camera ``(H, W)``.
    wavelengths
        Band wavelengths in nm (default: the bundle's bin centres).
    step
        Node spacing in camera px.

    Returns
    -------
    CameraLookup

    Examples
    --------
    >>> lookup = solve_camera_lookup(bundle, (512, 800))
    >>> u, v = lookup.band(10)
    """
    lam = np.atleast_1d(
        np.asarray(bundle.wavelengths if wavelengths is None else wavelengths, dtype=np.float64)
    )
    height, width = (int(n) for n in camera_shape)
    if lam.ndim != 1 or lam.size == 0 or not np.all(np.isfinite(lam)):
        raise ProcedureError(
            step_error("camera lookup", f"wavelengths {lam!r} are not a list", "pass nm values")
        )
    if height < 2 or width < 2 or int(step) < 1:
        raise ProcedureError(
            step_error(
                "camera lookup",
                f"camera shape {camera_shape} or node step {step} is too small",
                "pass the spectral camera's (height, width) and a step of 1 px or more",
            )
        )
    step = int(step)
    node_x = np.arange(0, width - 1 + step, step, dtype=np.float64)
    node_y = np.arange(0, height - 1 + step, step, dtype=np.float64)
    y, x = (a.ravel() for a in np.meshgrid(node_y, node_x, indexing="ij"))
    inverse_m, inverse_c = _affine_inverse(bundle, lam)
    slm_h, slm_w = bundle.slm_shape
    # Solve the nodes that bilinear interpolation can need near the SLM's image: a few
    # node spacings around it (the map's scale is at most a few camera px per SLM px).
    smallest_scale = np.abs(np.linalg.det(inverse_m)).max() ** -0.5  # camera px / SLM px
    margin = 2.0 * step / smallest_scale + 2.0
    grid = (lam.size, node_y.size, node_x.size)
    u_out, v_out = np.full(grid, np.nan), np.full(grid, np.nan)
    for t, wavelength in enumerate(lam):
        u0 = inverse_m[t, 0, 0] * x + inverse_m[t, 0, 1] * y + inverse_c[t, 0]
        v0 = inverse_m[t, 1, 0] * x + inverse_m[t, 1, 1] * y + inverse_c[t, 1]
        near = (
            (u0 > -0.5 - margin)
            & (u0 < slm_w - 0.5 + margin)
            & (v0 > -0.5 - margin)
            & (v0 < slm_h - 0.5 + margin)
        )
        u, v = _newton(bundle, float(wavelength), x[near], y[near], u0[near], v0[near])
        u_out[t].reshape(-1)[near] = u  # u_out[t] is contiguous: reshape is a view
        v_out[t].reshape(-1)[near] = v
    return CameraLookup(lam, (height, width), (slm_h, slm_w), step, u_out, v_out)
