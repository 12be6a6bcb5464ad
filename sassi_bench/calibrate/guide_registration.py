"""Guide camera -> SLM registration: an RGB rendering of a scanned cube, SIFT, a homography.

The SASSI pipeline chooses sampling points on the guide image and opens them on the SLM,
so the guide camera and the SLM must agree to a fraction of a pixel. A pinhole scan of a
textured scene gives a cube on the SLM grid;
:func:`~sassi_bench.calibrate.guide_render.render_rgb` turns it into an RGB image
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

from sassi_bench.errors import ProcedureError, SassiBenchError, step_error

__all__ = [
    "METHODS",
    "Registration",
    "RegistrationError",
    "RegistrationQuality",
    "apply_homography",
    "field_discrepancy_px",
    "register_guide",
    "to_grey8",
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
        A rendering of the same scene on the SLM grid (H, W[, 3]) (``guide_render.render_rgb``).
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
        raise ProcedureError(
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
