"""The loaded calibration bundle: the stable API a reconstruction package uses.

Get one with :func:`sassi_bench.bundle.load`; it is immutable (a frozen dataclass whose arrays
are read-only and whose manifest is a read-only mapping).

Examples
--------
>>> from sassi_bench.bundle import load
>>> bundle = load(rig="sim")
>>> x, y = bundle.slm_to_camera(320, 200, bundle.wavelengths)
>>> streak = bundle.streak(320, 200)
>>> round(float(np.median(streak.x_right - streak.x_left)), 2)  # camera px per bin
1.0
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_dtype_kind, check_ndim
from sassi_bench.bundle.errors import BundleError
from sassi_bench.bundle.models import CalibrationModels
from sassi_bench.bundle.spacing import MaskSpacing, mask_spacing
from sassi_bench.errors import step_error

__all__ = ["CalibrationBundle", "Streak"]


class Streak(NamedTuple):
    """The spectral streak of one SLM pixel on the camera, one entry per wavelength bin.

    All fields are read-only float64 ``(B,)`` arrays.

    Attributes
    ----------
    wavelength_nm
        Bin centres.
    x, y
        Camera position of the bin centre.
    x_left, x_right
        Camera x of the bin's two edges, ordered so that ``x_left <= x <= x_right`` whichever
        way the prism disperses.
    window_px
        Half-width, in camera rows, of the summation window at the bin (from the blur model).
    """

    wavelength_nm: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    x_left: NDArray[np.float64]
    x_right: NDArray[np.float64]
    window_px: NDArray[np.float64]


def _readonly(array: ArrayLike) -> NDArray[np.float64]:
    out = np.array(array, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class CalibrationBundle:
    """A verified, immutable calibration bundle.

    Build it with :func:`sassi_bench.bundle.load`, which checks the schema and every checksum
    first; constructing one directly skips those checks.

    Parameters
    ----------
    path
        The bundle folder.
    manifest
        The (migrated) manifest as a read-only mapping.
    models
        The parsed models.
    arrays
        Every array of the bundle by name (read-only).
    migrated_from
        The schema version the manifest was migrated from on load, or None.

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> bundle = load(rig="sim", version="latest")
    >>> bundle.version, bundle.passed
    ('v0002', True)
    >>> bundle.blur_width([405.0, 520.0, 635.0]).round(6).tolist()
    [4.0, 1.0, 4.0]
    """

    path: Path
    manifest: Mapping[str, Any]
    models: CalibrationModels
    arrays: Mapping[str, NDArray[Any]]
    migrated_from: str | None = None

    # -- identity ---------------------------------------------------------------------------

    @property
    def version(self) -> str:
        """Version name, e.g. ``"v0003"``."""
        return str(self.manifest["version"])

    @property
    def rig_name(self) -> str:
        """Name of the rig the bundle calibrates."""
        return str(self.manifest["rig_name"])

    @property
    def passed(self) -> bool:
        """True if every quality check passed."""
        return bool(self.manifest["passed"])

    @property
    def override(self) -> bool:
        """True if the bundle was published although a quality check failed."""
        return bool(self.manifest["override"])

    @property
    def created(self) -> str:
        """UTC time of publication (ISO 8601)."""
        return str(self.manifest["created"])

    @property
    def parent(self) -> str | None:
        """The version this one supersedes, or None."""
        parent = self.manifest["parent"]
        return None if parent is None else str(parent)

    @property
    def slm_shape(self) -> tuple[int, int]:
        """SLM ``(H, W)`` in pixels."""
        return self.models.dispersion.slm_shape

    # -- wavelength bins ----------------------------------------------------------------------

    @property
    def wavelengths(self) -> NDArray[np.float64]:
        """Bin centres in nm, ``(B,)`` float64."""
        return self.models.bins.centres_nm

    @property
    def bin_edges(self) -> NDArray[np.float64]:
        """Bin edges in nm, ``(B + 1,)`` float64."""
        return self.models.bins.edges_nm

    @property
    def bin_resolution_nm(self) -> NDArray[np.float64]:
        """Spectral resolution of each bin in nm, ``(B,)`` float64."""
        return self.models.bins.resolution_nm

    # -- geometry -----------------------------------------------------------------------------

    def slm_to_camera(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera ``(x, y)`` where SLM pixel ``(u, v)`` lands at ``wavelength_nm``.

        Parameters
        ----------
        u, v
            SLM column and row (pixel centres at integers); any shapes.
        wavelength_nm
            Wavelength(s) in nm; broadcast with ``u`` and ``v`` (numpy rules).

        Returns
        -------
        x, y : ndarray
            float64 arrays of the broadcast shape. Points outside the SLM are extrapolated.

        Examples
        --------
        >>> u, v = np.meshgrid(np.arange(0, 640, 80), np.arange(0, 400, 80))
        >>> lam = bundle.wavelengths
        >>> x, y = bundle.slm_to_camera(u[..., None], v[..., None], lam)
        >>> x.shape
        (5, 8, 68)
        """
        return self.models.dispersion.evaluate(u, v, wavelength_nm)

    def streak(self, u: float, v: float) -> Streak:
        """The streak of one SLM pixel, one entry per wavelength bin.

        Parameters
        ----------
        u, v
            SLM column and row of the pixel (scalars inside the SLM).

        Returns
        -------
        Streak

        Raises
        ------
        BundleError
            If ``(u, v)`` is not a finite scalar pair inside the SLM.

        Examples
        --------
        >>> s = bundle.streak(320, 200)
        >>> bool(np.all(s.x_left <= s.x) and np.all(s.x <= s.x_right))
        True
        """
        height, width = self.slm_shape
        if np.ndim(u) != 0 or np.ndim(v) != 0:
            raise BundleError(
                step_error(
                    "bundle streak",
                    f"(u, v) must be scalars, got shapes {np.shape(u)} and {np.shape(v)}",
                    "call streak() per pixel, or slm_to_camera() for many points at once",
                )
            )
        u_f, v_f = float(u), float(v)
        if not (-0.5 <= u_f <= width - 0.5 and -0.5 <= v_f <= height - 0.5):
            raise BundleError(
                step_error(
                    "bundle streak",
                    f"SLM pixel ({u_f:g}, {v_f:g}) is outside the {width}x{height} SLM",
                    f"pass 0 <= u <= {width - 1} and 0 <= v <= {height - 1}",
                )
            )
        dispersion = self.models.dispersion
        centres = self.wavelengths
        x, y = dispersion.evaluate(u_f, v_f, centres)
        x_edges, _ = dispersion.evaluate(u_f, v_f, self.bin_edges)
        return Streak(
            wavelength_nm=centres,
            x=_readonly(x),
            y=_readonly(y),
            x_left=_readonly(np.minimum(x_edges[:-1], x_edges[1:])),
            x_right=_readonly(np.maximum(x_edges[:-1], x_edges[1:])),
            window_px=_readonly(self.models.blur.window_half_width(centres)),
        )

    def blur_width(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Gaussian blur sigma in camera px at ``wavelength_nm`` (vectorised).

        Examples
        --------
        >>> bundle.blur_width(bundle.wavelengths).shape
        (68,)
        """
        return self.models.blur.sigma(wavelength_nm)

    # -- guide camera -------------------------------------------------------------------------

    @property
    def guide_to_slm(self) -> NDArray[np.float64] | None:
        """3x3 float64 homography guide ``(p, q, 1)`` -> SLM ``(u, v, 1)``, or None."""
        return self.models.guide_to_slm

    def warp_guide_to_slm(
        self, image: ArrayLike, *, interpolation: int | None = None
    ) -> NDArray[Any]:
        """Resample a guide-camera image onto the SLM grid.

        Parameters
        ----------
        image
            Guide image ``(rows, cols)`` or ``(rows, cols, channels)``; dtype uint8, uint16,
            int16, float32 or float64.
        interpolation
            OpenCV interpolation flag (default ``cv2.INTER_LINEAR``).

        Returns
        -------
        ndarray
            Image of the SLM's shape ``(H, W[, channels])``; pixels that see nothing are 0.

        Raises
        ------
        BundleError
            If the bundle has no guide homography, or the image cannot be warped.

        Examples
        --------
        >>> guide_rgb = np.zeros((540, 720, 3), np.uint8)  # a guide camera frame
        >>> slm_view = bundle.warp_guide_to_slm(guide_rgb)
        >>> slm_view.shape[:2] == bundle.slm_shape
        True
        """
        import cv2  # imported here: OpenCV is only needed by this method

        if self.guide_to_slm is None:
            raise BundleError(
                step_error(
                    "bundle warp_guide_to_slm",
                    f"bundle {self.rig_name}/{self.version} has no guide -> SLM homography",
                    "run the guide homography calibration and publish a new bundle, "
                    "or load a bundle that has one",
                )
            )
        array = np.asarray(image)
        step = "bundle warp_guide_to_slm"
        fix = "pass a (rows, cols) or (rows, cols, channels) numeric image"
        check_ndim(
            array,
            (2, 3),
            step=step,
            name="the image",
            fix=fix,
            allow_empty=False,
            error=BundleError,
        )
        check_dtype_kind(array, "uif", step=step, name="the image", fix=fix, error=BundleError)
        height, width = self.slm_shape
        flags = cv2.INTER_LINEAR if interpolation is None else int(interpolation)
        try:
            return cv2.warpPerspective(
                np.ascontiguousarray(array),
                np.asarray(self.guide_to_slm, dtype=np.float64),
                (width, height),
                flags=flags,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0,
            )
        except cv2.error as exc:
            raise BundleError(
                step_error(
                    "bundle warp_guide_to_slm",
                    f"OpenCV could not warp an image of shape {array.shape} and dtype "
                    f"{array.dtype} ({str(exc).strip().splitlines()[-1]})",
                    "pass uint8, uint16, int16, float32 or float64 with at most 4 channels",
                )
            ) from exc

    # -- mask design --------------------------------------------------------------------------

    def mask_spacing(
        self,
        *,
        blur_sigmas: float = 3.0,
        margin_px: float = 3.0,
        row_sigmas: float | None = None,
        row_pitch: int | None = None,
    ) -> MaskSpacing:
        """How far apart open SLM pixels must be so that their streaks never overlap.

        The forbidden window of every SLM pixel, from the streak extent (400-700 nm) plus
        ``blur_sigmas`` blur sigmas at both ends (``row_sigmas`` above and below, by default
        the same); see :mod:`sassi_bench.bundle.spacing` for the exact rule.

        Examples
        --------
        >>> spacing = bundle.mask_spacing()
        >>> spacing.window(320, 200)  # rows v0..v1, columns u0..u1
        (181, 219, 280, 360)
        """
        return mask_spacing(
            self.models, blur_sigmas=blur_sigmas, margin_px=margin_px, row_sigmas=row_sigmas,
            row_pitch=row_pitch,
        )  # fmt: skip

    # -- other models -------------------------------------------------------------------------

    @property
    def offset_model(self) -> Mapping[str, Any] | None:
        """Parameters of the background-offset model (read-only mapping), or None."""
        return self.models.offset

    @property
    def response(self) -> NDArray[np.float64] | None:
        """Per-bin system response ``(B,)``, or None."""
        return self.models.response

    def __repr__(self) -> str:
        status = "passed" if self.passed else "FAILED (override)"
        return (
            f"CalibrationBundle(rig={self.rig_name!r}, version={self.version!r}, "
            f"bins={self.models.bins.count}, {status}, path={str(self.path)!r})"
        )
