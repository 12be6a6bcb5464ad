"""Guide camera -> SLM registration: an RGB rendering of a scanned cube, SIFT, a homography.

The SASSI pipeline chooses sampling points on the guide image and opens them on the SLM,
so the guide camera and the SLM must agree to a fraction of a pixel. A pinhole scan of a
textured scene gives a cube on the SLM grid; :func:`render_rgb` turns it into an RGB image
(through the guide camera's spectral sensitivities when they are known, otherwise
CIE 1931 -> sRGB), and :func:`register_guide` matches that rendering to a guide image:

1. SIFT keypoints and descriptors on both images (OpenCV), the SLM side restricted to
   measured pixels;
2. Lowe's ratio test on the two nearest neighbours;
3. a robust homography guide ``(p, q, 1)`` -> SLM ``(u, v, 1)`` (USAC MAGSAC++ or RANSAC);
4. refinement on the inliers: a robust (Huber) least-squares fit of the eight free
   parameters to the SLM-side reprojection error, inliers re-selected once;
5. optionally a dense photometric refinement from there: OpenCV's enhanced correlation
   coefficient (ECC) maximisation over every pixel both images share. Feature positions
   carry a few tenths of a pixel of noise each; the dense fit averages over the whole
   overlap and is kept only if it stays within the inlier threshold of the feature fit.

The quality of a fit (:class:`RegistrationQuality`) is the inliers' reprojection RMS, the
inlier count and ratio, and how much of the SLM field the inliers span. Too few matches,
or matches bunched in a corner, raise an error that says what to put in front of the
camera.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from sassi_bench.errors import ConfigError, SassiBenchError, step_error

__all__ = [
    "METHODS",
    "Registration",
    "RegistrationError",
    "RegistrationQuality",
    "apply_homography",
    "camera_sensitivities",
    "field_discrepancy_px",
    "register_guide",
    "render_rgb",
    "rendering_sensitivities",
    "to_grey8",
    "upsample_lattice",
]

STEP = "guide registration"

#: Robust estimators accepted by :func:`register_guide`.
METHODS = {"usac_magsac": cv2.USAC_MAGSAC, "ransac": cv2.RANSAC}

_SCENE_ADVICE = (
    "put a flat, well-lit, richly textured target (a printed photograph, a page of small "
    "print, a circuit board) filling the whole field in front of the camera, make sure the "
    "guide image shows the same scene that was scanned, in focus, and neither dark nor "
    "saturated"
)


class RegistrationError(SassiBenchError, ValueError):
    """The guide image and the SLM rendering could not be registered reliably."""


# -- rendering -----------------------------------------------------------------------------


def camera_sensitivities(name: str, wavelengths_nm: ArrayLike) -> NDArray[np.float64]:
    """RGB spectral sensitivities (3, L) of a named camera, sampled at ``wavelengths_nm``.

    The names are those of colour-science's camera sensitivity data sets
    (``colour.MSDS_CAMERA_SENSITIVITIES``); a rig description names its guide camera's
    sensor in ``guide_camera.sensitivities``. Peak normalised to 1, zero outside the data.

    Raises
    ------
    ConfigError
        If colour-science does not know the camera.

    Examples
    --------
    >>> s = camera_sensitivities("Nikon 5100 (NPL)", [450.0, 550.0, 650.0])
    >>> s.shape, int(np.argmax(s[:, 0])), int(np.argmax(s[:, 2]))
    ((3, 3), 2, 0)
    """
    import colour

    if name not in colour.MSDS_CAMERA_SENSITIVITIES:
        raise ConfigError(
            step_error(
                STEP,
                f"unknown guide camera sensitivities {name!r}",
                f"name one of {sorted(colour.MSDS_CAMERA_SENSITIVITIES)} in the rig's "
                "guide_camera.sensitivities, or render with method='cie'",
            )
        )
    msds = colour.MSDS_CAMERA_SENSITIVITIES[name]
    values = np.asarray(msds.values, dtype=np.float64)
    grid = np.asarray(wavelengths_nm, dtype=np.float64)
    out = np.stack(
        [np.interp(grid, msds.wavelengths, values[:, c], left=0.0, right=0.0) for c in range(3)]
    )
    return out / out.max()


def rendering_sensitivities(
    sensor: str, method: str, wavelengths_nm: ArrayLike
) -> tuple[NDArray[np.float64] | None, str]:
    """The sensitivities :func:`render_rgb` should use, and a label for the bundle.

    Parameters
    ----------
    sensor
        The guide sensor the rig description names (``guide_camera.sensitivities``).
    method
        ``"camera"`` (the sensor's sensitivities, an error if unknown), ``"cie"``
        (CIE 1931 -> sRGB) or ``"auto"`` (the sensor's when known, else CIE).
    wavelengths_nm
        Bin centres.

    Examples
    --------
    >>> rendering_sensitivities("a lab camera", "auto", [500.0, 600.0])
    (None, 'cie')
    >>> rendering_sensitivities("Nikon 5100 (NPL)", "auto", [500.0, 600.0])[1]
    'camera: Nikon 5100 (NPL)'
    """
    if method not in ("auto", "camera", "cie"):
        raise ValueError(
            step_error(STEP, f"unknown rendering {method!r}", "use auto, camera or cie")
        )
    if method == "cie":
        return None, "cie"
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
    data = np.asarray(cube, dtype=np.float64)
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    if data.ndim != 3 or data.shape[-1] != wl.size:
        raise ValueError(
            step_error(
                STEP,
                f"cube of shape {data.shape} does not match {wl.size} wavelengths",
                "pass an (H, W, B) cube with its B bin centres",
            )
        )
    mask = np.ones(data.shape[:2], bool) if valid is None else np.asarray(valid, bool)
    data = np.where(mask[..., None] & np.isfinite(data), data, 0.0)
    if sensitivities is not None:
        weights = np.asarray(sensitivities, dtype=np.float64)
        if weights.shape != (3, wl.size):
            raise ValueError(
                step_error(
                    STEP, f"sensitivities have shape {weights.shape}", f"pass (3, {wl.size})"
                )
            )
        rgb = np.clip(data @ weights.T, 0.0, None)
    else:
        import colour

        xyz = np.clip(data @ _cie_cmfs(wl).T, 0.0, None)
        peak = _peak(xyz[..., 1], mask, percentile)
        rgb = np.clip(colour.XYZ_to_sRGB(xyz / peak), 0.0, None)
    peak = _peak(rgb.max(axis=-1), mask, percentile)
    return np.clip(rgb / peak, 0.0, 1.0).astype(np.float32)


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


def to_grey8(
    image: ArrayLike, mask: ArrayLike | None = None, *, low: float = 0.5, high: float = 99.5
) -> NDArray[np.uint8]:
    """An 8-bit grey image for feature detection: channel mean, robust contrast stretch.

    Examples
    --------
    >>> to_grey8(np.array([[0.0, 1.0], [2.0, 3.0]]), low=0, high=100).tolist()
    [[0, 85], [170, 255]]
    """
    data = np.asarray(image, dtype=np.float64)
    grey = data.mean(axis=-1) if data.ndim == 3 else data
    keep = np.isfinite(grey)
    if mask is not None:
        keep &= np.asarray(mask, bool)
    if not keep.any():
        return np.zeros(grey.shape, np.uint8)
    lo, hi = np.percentile(grey[keep], [low, high])
    scaled = (grey - lo) / max(hi - lo, 1e-12)
    out = np.clip(np.nan_to_num(scaled) * 255.0 + 0.5, 0, 255).astype(np.uint8)
    out[~keep] = 0
    return out


# -- homography helpers ----------------------------------------------------------------------


def apply_homography(h: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Map (N, 2) points through a 3x3 homography.

    Examples
    --------
    >>> apply_homography(np.diag([2.0, 3.0, 1.0]), [[1.0, 1.0]]).tolist()
    [[2.0, 3.0]]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    mapped = np.column_stack([pts, np.ones(len(pts))]) @ np.asarray(h, dtype=np.float64).T
    return mapped[:, :2] / mapped[:, 2:3]


def _field_grid(slm_shape: tuple[int, int], step_px: float) -> NDArray[np.float64]:
    h, w = slm_shape
    u, v = np.meshgrid(
        np.linspace(0, w - 1, max(2, round((w - 1) / step_px) + 1)),
        np.linspace(0, h - 1, max(2, round((h - 1) / step_px) + 1)),
    )
    return np.column_stack([u.ravel(), v.ravel()])


def field_discrepancy_px(
    h_a: ArrayLike, h_b: ArrayLike, slm_shape: tuple[int, int], step_px: float = 8.0
) -> tuple[float, float]:
    """RMS and maximum distance (SLM px) between two guide -> SLM homographies over the field.

    A grid spanning the SLM is taken back to the guide image through ``h_b`` and forward
    through ``h_a``; the distances to the grid points are summarised.

    Examples
    --------
    >>> shift = np.array([[1.0, 0, 0.3], [0, 1.0, -0.4], [0, 0, 1.0]])
    >>> [round(x, 6) for x in field_discrepancy_px(shift, np.eye(3), (40, 60))]
    [0.5, 0.5]
    """
    grid = _field_grid(slm_shape, step_px)
    guide = apply_homography(np.linalg.inv(np.asarray(h_b, dtype=np.float64)), grid)
    d = np.hypot(*(apply_homography(h_a, guide) - grid).T)
    return float(np.sqrt(np.mean(d**2))), float(d.max())


# -- registration ---------------------------------------------------------------------------


@dataclass(frozen=True)
class RegistrationQuality:
    """How well a guide -> SLM homography is supported by its feature matches.

    Attributes
    ----------
    matches
        Correspondences that passed the ratio test.
    inliers
        Matches the refined homography explains within the threshold.
    inlier_ratio
        ``inliers / matches``.
    rms_px
        Reprojection RMS of the inliers on the SLM (SLM px), for the final homography.
    coverage
        Fraction of the SLM field inside the convex hull of the inliers' SLM positions.
    dense_correlation
        The ECC correlation coefficient of the dense refinement (None: not run or rejected).
    dense_shift_px
        Largest move over the SLM field from the feature fit to the dense one, SLM px.
    """

    matches: int
    inliers: int
    inlier_ratio: float
    rms_px: float
    coverage: float
    dense_correlation: float | None = None
    dense_shift_px: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible form (for the bundle's ``guide_info``)."""
        return asdict(self)


@dataclass(frozen=True)
class Registration:
    """A guide -> SLM homography with the matches it came from.

    Attributes
    ----------
    homography
        3x3, guide ``(p, q, 1)`` -> SLM ``(u, v, 1)``, normalised so ``h[2, 2] == 1``.
    quality
        :class:`RegistrationQuality`.
    guide_points, slm_points
        (N, 2) matched positions (guide px, SLM px) of every ratio-test survivor.
    inlier
        (N,) bool, the matches the homography explains.
    method
        The robust estimator used.
    """

    homography: NDArray[np.float64]
    quality: RegistrationQuality
    guide_points: NDArray[np.float64]
    slm_points: NDArray[np.float64]
    inlier: NDArray[np.bool_]
    method: str

    def info(self) -> dict[str, Any]:
        """Facts for the bundle (quality plus the estimator)."""
        steps = f"SIFT + {self.method} + Huber refinement"
        if self.quality.dense_correlation is not None:
            steps += " + ECC"
        return {**self.quality.to_dict(), "method": steps}


def _detect(sift, image: NDArray[np.uint8], mask: NDArray[np.uint8] | None):
    keypoints, descriptors = sift.detectAndCompute(image, mask)
    points = np.array([k.pt for k in keypoints], dtype=np.float64).reshape(-1, 2)
    return points, descriptors


def _ratio_matches(desc_a, desc_b, ratio: float) -> NDArray[np.intp]:
    if desc_a is None or desc_b is None or len(desc_a) < 2 or len(desc_b) < 2:
        return np.zeros((0, 2), np.intp)
    pairs = cv2.BFMatcher(cv2.NORM_L2).knnMatch(desc_a, desc_b, k=2)
    good = [
        (m.queryIdx, m.trainIdx) for m, n in (p for p in pairs if len(p) == 2)
        if m.distance < ratio * n.distance
    ]  # fmt: skip
    matched = np.array(good, dtype=np.intp).reshape(-1, 2)
    # One SLM keypoint may attract several guide keypoints: keep only unique pairs.
    _, first = np.unique(matched[:, 1], return_index=True)
    return matched[np.sort(first)]


def _residuals(h: NDArray[np.float64], src, dst) -> NDArray[np.float64]:
    return np.hypot(*(apply_homography(h, src) - dst).T)


def _refine(h0: NDArray[np.float64], src, dst, scale_px: float) -> NDArray[np.float64]:
    """Huber least squares of the SLM-side reprojection error, in normalised coordinates."""
    ns, nd = _normaliser(src), _normaliser(dst)
    s, d = apply_homography(ns, src), apply_homography(nd, dst)
    g = nd @ h0 @ np.linalg.inv(ns)
    g /= g[2, 2]

    def fun(x):
        m = np.append(x, 1.0).reshape(3, 3)
        return (apply_homography(m, s) - d).ravel()

    f_scale = scale_px * nd[0, 0]
    fit = least_squares(fun, g.ravel()[:8], loss="huber", f_scale=f_scale, method="trf")
    h = np.linalg.inv(nd) @ np.append(fit.x, 1.0).reshape(3, 3) @ ns
    return h / h[2, 2]


def _normaliser(points: NDArray[np.float64]) -> NDArray[np.float64]:
    centre = points.mean(axis=0)
    spread = float(np.sqrt(np.mean(np.sum((points - centre) ** 2, axis=1)))) or 1.0
    k = np.sqrt(2.0) / spread
    return np.array([[k, 0, -k * centre[0]], [0, k, -k * centre[1]], [0, 0, 1.0]])


def _coverage(points: NDArray[np.float64], slm_shape: tuple[int, int]) -> float:
    if len(points) < 3:
        return 0.0
    hull = cv2.convexHull(points.astype(np.float32))
    return float(cv2.contourArea(hull)) / float(slm_shape[0] * slm_shape[1])


def register_guide(
    guide_image: ArrayLike,
    slm_image: ArrayLike,
    *,
    slm_valid: ArrayLike | None = None,
    guide_valid: ArrayLike | None = None,
    ratio: float = 0.75,
    method: str = "usac_magsac",
    threshold_px: float = 1.5,
    min_inliers: int = 30,
    min_coverage: float = 0.25,
    sift_options: Mapping[str, Any] | None = None,
    dense: bool = True,
) -> Registration:
    """Fit the guide -> SLM homography from SIFT matches between the two images.

    Parameters
    ----------
    guide_image
        The guide camera's image (H_g, W_g[, 3]), any numeric type (dark level removed).
    slm_image
        A rendering of the same scene on the SLM grid (H, W[, 3]) (:func:`render_rgb`).
    slm_valid, guide_valid
        Optional bool masks of usable pixels (e.g. measured scan pixels).
    ratio
        Lowe's ratio test threshold (nearest / second-nearest descriptor distance).
    method
        ``"usac_magsac"`` (MAGSAC++) or ``"ransac"``.
    threshold_px
        Inlier threshold on the SLM, SLM px.
    min_inliers, min_coverage
        Below either, a :class:`RegistrationError` says what to put in front of the camera.
    sift_options
        Keyword arguments for ``cv2.SIFT_create`` (e.g. ``contrastThreshold``).
    dense
        Refine the feature fit by ECC maximisation over the shared pixels.

    Returns
    -------
    Registration

    Raises
    ------
    RegistrationError
        Too few matches or inliers (a textureless or different scene), or inliers that
        cover too little of the SLM field.

    Examples
    --------
    >>> from skimage import data
    >>> slm = data.astronaut()[::2, ::2]
    >>> h_true = np.array([[1.1, 0.05, -12.0], [-0.04, 1.08, -8.0], [0.0, 0.0, 1.0]])
    >>> guide = cv2.warpPerspective(slm, np.linalg.inv(h_true), (256, 256))
    >>> reg = register_guide(guide, slm)
    >>> field_discrepancy_px(reg.homography, h_true, slm.shape[:2])[0] < 0.05
    True
    """
    if method not in METHODS:
        raise ValueError(
            step_error(STEP, f"unknown method {method!r}", f"use one of {list(METHODS)}")
        )
    slm_arr = np.asarray(slm_image)
    slm_shape = (int(slm_arr.shape[0]), int(slm_arr.shape[1]))
    slm_mask = None if slm_valid is None else np.asarray(slm_valid, bool)
    guide_mask = None if guide_valid is None else np.asarray(guide_valid, bool)
    slm8 = to_grey8(slm_arr, slm_mask)
    guide8 = to_grey8(guide_image, guide_mask)
    sift = cv2.SIFT_create(**dict(sift_options or {}))
    mask8 = None if slm_mask is None else _eroded(slm_mask)
    gmask8 = None if guide_mask is None else _eroded(guide_mask)
    g_pts, g_desc = _detect(sift, guide8, gmask8)
    s_pts, s_desc = _detect(sift, slm8, mask8)
    pairs = _ratio_matches(g_desc, s_desc, ratio)
    src, dst = g_pts[pairs[:, 0]], s_pts[pairs[:, 1]]
    n = len(pairs)
    if n < max(min_inliers, 8):
        raise RegistrationError(
            step_error(
                STEP,
                f"only {n} SIFT matches passed the ratio test ({len(g_pts)} keypoints on the "
                f"guide image, {len(s_pts)} on the SLM rendering; at least "
                f"{max(min_inliers, 8)} needed): the scene is too plain, or the guide camera "
                "sees a different scene from the one scanned",
                _SCENE_ADVICE,
            )
        )
    h0, mask = cv2.findHomography(
        src, dst, METHODS[method], threshold_px, maxIters=20000, confidence=0.9999
    )
    if h0 is None:
        raise RegistrationError(
            step_error(STEP, f"no homography is consistent with the {n} matches", _SCENE_ADVICE)
        )
    inlier = mask.ravel().astype(bool)
    h = h0 / h0[2, 2]
    for _ in range(2):  # refine on the inliers, then re-select them with the refined model
        if inlier.sum() < 8:
            break
        h = _refine(h, src[inlier], dst[inlier], threshold_px / 3.0)
        inlier = _residuals(h, src, dst) < threshold_px
    correlation = shift = None
    if dense and inlier.sum() >= min_inliers:
        refined = _dense_refine(h, guide8, slm8, slm_mask, guide_mask)
        if refined is not None:
            shift = field_discrepancy_px(refined[0], h, slm_shape)[1]
            if shift <= threshold_px:
                h, correlation = refined
    residual = _residuals(h, src[inlier], dst[inlier])
    quality = RegistrationQuality(
        matches=n,
        inliers=int(inlier.sum()),
        inlier_ratio=float(inlier.mean()),
        rms_px=float(np.sqrt(np.mean(residual**2))) if residual.size else float("inf"),
        coverage=_coverage(dst[inlier], slm_shape),
        dense_correlation=correlation,
        dense_shift_px=shift,
    )
    if quality.inliers < min_inliers:
        raise RegistrationError(
            step_error(
                STEP,
                f"only {quality.inliers} of {n} matches agree on one homography (at least "
                f"{min_inliers} needed): the matches are mostly chance pairings",
                _SCENE_ADVICE,
            )
        )
    if quality.coverage < min_coverage:
        raise RegistrationError(
            step_error(
                STEP,
                f"the {quality.inliers} inliers span only {quality.coverage:.0%} of the SLM "
                f"field (at least {min_coverage:.0%} needed), so the homography is "
                "extrapolated over the rest",
                "use a target with texture over the whole field, not only in one region; "
                + _SCENE_ADVICE,
            )
        )
    return Registration(h, quality, src, dst, inlier, method)


def _dense_refine(h, guide8, slm8, slm_mask, guide_mask, smoothing: int = 3):
    """ECC maximisation, guide image as template and the SLM rendering warped onto it.

    With the guide as the template the warp OpenCV estimates is guide -> SLM itself, and
    the SLM rendering's unmeasured pixels are excluded through ECC's input mask.
    """
    template = guide8.astype(np.float32)
    if guide_mask is not None:  # unusable guide pixels take the mean: no false edges
        template[~guide_mask] = float(template[guide_mask].mean())
    mask = None if slm_mask is None else _eroded(slm_mask, 2)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 200, 1e-7)
    try:
        correlation, warp = cv2.findTransformECC(
            template,
            slm8.astype(np.float32),
            np.asarray(h, dtype=np.float32),
            cv2.MOTION_HOMOGRAPHY,
            criteria,
            mask,
            smoothing,
        )
    except cv2.error:  # ECC did not converge (too little overlap or contrast)
        return None
    refined = warp.astype(np.float64)
    return refined / refined[2, 2], float(correlation)


def _eroded(mask: NDArray[np.bool_], border: int = 8) -> NDArray[np.uint8]:
    """Detection mask (uint8) away from the edges of the usable region (no edge features)."""
    kernel = np.ones((2 * border + 1, 2 * border + 1), np.uint8)
    return cv2.erode(
        mask.astype(np.uint8) * 255, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0
    )
