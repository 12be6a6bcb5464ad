"""The guide registration's reductions: a scan rendered on the SLM grid, the guide image,
the homography graded, and the bundle.

:func:`slm_reference` renders a scanned cube as RGB on the SLM grid through the guide
sensor's sensitivities (resampled from the scan's lattice onto every SLM pixel);
:func:`guide_image` averages a guide session's lit and dark frames; :func:`register`
fits the guide -> SLM homography
(:func:`~sassi_bench.calibrate.guide_registration.register_guide`) and grades it against
the procedure's tolerances; :func:`publish_guide` publishes a new bundle version: the
parent's models plus the homography and its quality.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle, QualityCheck, publish_derived
from sassi_bench.calibrate.guide_registration import Registration, register_guide
from sassi_bench.calibrate.guide_render import (
    render_rgb,
    rendering_sensitivities,
    upsample_lattice,
)
from sassi_bench.rig.config import RigDescription
from sassi_bench.spectra.scan import ScanCube

__all__ = [
    "GuideRegistration",
    "SlmReference",
    "guide_image",
    "publish_guide",
    "register",
    "render_figures",
    "slm_reference",
]


@dataclass(frozen=True)
class SlmReference:
    """An RGB rendering of a scanned scene on the SLM grid, and where it came from.

    Attributes
    ----------
    image
        (H, W, 3) float32 in [0, 1].
    valid
        (H, W) bool, pixels rendered from measured spectra.
    rendering
        ``"camera: <sensor>"`` or ``"cie"``.
    scene
        The scene that was scanned.
    session
        The scan session.
    stride
        (horizontal, vertical) pinhole-offset stride of the scan.
    """

    image: NDArray[np.float32]
    valid: NDArray[np.bool_]
    rendering: str
    scene: str
    session: Session
    stride: tuple[int, int]


@dataclass
class GuideRegistration:
    """Everything the guide registration produced."""

    procedure: dict[str, Any]
    rig_description: Any
    registration: Registration
    reference: SlmReference
    guide_image: NDArray[np.float64]
    guide_valid: NDArray[np.bool_]
    guide_session: Session
    checks: list[QualityCheck]
    bundle_path: Path | None = None
    figures: dict[str, bytes] = field(default_factory=dict)

    @property
    def homography(self) -> NDArray[np.float64]:
        """3x3 guide ``(p, q, 1)`` -> SLM ``(u, v, 1)``."""
        return self.registration.homography

    @property
    def passed(self) -> bool:
        """Whether every quality check passed."""
        return all(c.passed for c in self.checks)


def slm_reference(
    scan: ScanCube,
    session: Session,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    desc: RigDescription,
    stride: tuple[int, int],
) -> SlmReference:
    """A scan's cube rendered as RGB on the SLM grid (radiance if the bundle has a
    response), resampled from its lattice of measured pixels onto every SLM pixel.

    Parameters
    ----------
    scan
        The assembled scan (every ``stride``-th pinhole offset measured).
    session
        Its session.
    bundle
        The bundle it was assembled with (its response).
    procedure
        The guide-registration procedure (``scene``, ``rendering``).
    desc
        The rig's description (the guide sensor it names).
    stride
        (horizontal, vertical) pinhole-offset stride of the scan.

    Returns
    -------
    SlmReference

    Examples
    --------
    Not run here (it needs captured sessions)::

        ref = slm_reference(scan, session, bundle, proc, desc, (4, 1))
    """
    cube = scan.cube[:: stride[1], :: stride[0]]
    if bundle.response is not None:
        cube = cube / np.asarray(bundle.response, dtype=np.float32)
    valid = scan.quality[:: stride[1], :: stride[0]] == 0
    sensitivities, label = rendering_sensitivities(
        desc.guide_camera.sensitivities, str(procedure["rendering"]), scan.wavelengths_nm
    )
    rgb = render_rgb(cube, scan.wavelengths_nm, sensitivities=sensitivities, valid=valid)
    image, image_valid = upsample_lattice(rgb, valid, stride, (desc.slm.height, desc.slm.width))
    scene = str(procedure["scene"])
    return SlmReference(np.clip(image, 0.0, 1.0), image_valid, label, scene, session, stride)


def guide_image(session: Session, bit_depth: int) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """A guide session's lit frames averaged minus its dark frames averaged, and the pixels
    no lit frame saturated.

    Parameters
    ----------
    session
        Frames tagged ``role: guide`` and ``role: guide_dark``.
    bit_depth
        The guide camera's bit depth.

    Returns
    -------
    image : ndarray
        float64, lit minus dark frames, each averaged.
    valid : ndarray
        bool (H, W), pixels no lit frame saturated.

    Examples
    --------
    Not run here (it needs captured sessions)::

        image, valid = guide_image(session, 12)
    """
    lit = session.read_frames(session.plan.select(role="guide")).astype(np.float64)
    dark = session.read_frames(session.plan.select(role="guide_dark")).astype(np.float64)
    saturation = 2**bit_depth - 1
    valid = np.all(lit < saturation, axis=(0, -1)) if lit.ndim == 4 else np.all(lit < saturation, 0)
    return lit.mean(axis=0) - dark.mean(axis=0), valid


def register(
    guide: NDArray[np.float64],
    guide_valid: NDArray[np.bool_],
    guide_session: Session,
    reference: SlmReference,
    procedure: Mapping[str, Any],
    desc: RigDescription,
) -> GuideRegistration:
    """Fit the guide -> SLM homography of a guide image to a rendering and grade it.

    Parameters
    ----------
    guide, guide_valid, guide_session
        The guide image, its unsaturated pixels and its session (:func:`guide_image`).
    reference
        The scene rendered on the SLM grid (:func:`slm_reference`).
    procedure
        The guide-registration procedure (``match``, ``tolerances``).
    desc
        The rig's description.

    Returns
    -------
    GuideRegistration

    Raises
    ------
    RegistrationError
        Too few matches or too little coverage (with advice on the target to use).

    Examples
    --------
    Not run here (it needs captured sessions)::

        result = register(image, valid, session, reference, proc, desc)
    """
    match, tol = procedure["match"], procedure["tolerances"]
    registration = register_guide(
        guide,
        reference.image,
        slm_valid=reference.valid,
        guide_valid=guide_valid,
        ratio=float(match["ratio"]),
        method=str(match["method"]),
        threshold_px=float(match["threshold_px"]),
        min_inliers=int(tol["min_inliers"]),
        min_coverage=float(tol["min_coverage"]),
        sift_options={"contrastThreshold": float(match["contrast_threshold"])},
        dense=bool(match["dense"]),
    )
    return GuideRegistration(
        dict(procedure),
        desc,
        registration,
        reference,
        guide,
        guide_valid,
        guide_session,
        _checks(registration, tol),
    )


def render_figures(result: GuideRegistration) -> None:
    """The match and checkerboard figures into ``result.figures`` (PNG bytes by name).

    Examples
    --------
    Not run here (it needs captured sessions)::

        render_figures(result)
    """
    from sassi_bench.plots.guide import guide_figures
    from sassi_bench.plots.png import figure_png

    result.figures = {name: figure_png(fig) for name, fig in guide_figures(result).items()}


def _checks(reg: Registration, tol: Mapping[str, Any]) -> list[QualityCheck]:
    q = reg.quality
    return [
        QualityCheck.at_least("guide_inliers", float(q.inliers), float(tol["min_inliers"]), "1"),
        QualityCheck.at_least(
            "guide_inlier_ratio", q.inlier_ratio, float(tol["min_inlier_ratio"]), "1"
        ),
        QualityCheck.at_least("guide_coverage", q.coverage, float(tol["min_coverage"]), "1"),
        QualityCheck.at_most(
            "guide_reprojection_rms_px", q.rms_px, float(tol["reprojection_rms_px"]), "px"
        ),
    ]


def publish_guide(
    result: GuideRegistration,
    bundle: CalibrationBundle,
    *,
    data=None,
    allow_failed: bool = False,
) -> Path:
    """Publish ``bundle``'s models plus the guide homography as a new, derived bundle version.

    The new version carries ``bundle``'s quality checks (see
    :func:`~sassi_bench.bundle.publish_derived`): a parent published with an override is
    refused unless ``allow_failed``.

    Parameters
    ----------
    result
        A finished registration.
    bundle
        The parent bundle whose models the new version carries.
    data
        Data root for bundles.
    allow_failed
        Publish although a check failed (recorded as an override).

    Returns
    -------
    pathlib.Path
        The new bundle's folder.

    Examples
    --------
    Not run here (it needs captured sessions)::

        path = publish_guide(result, bundle)
    """
    ref = result.reference
    info = {
        **result.registration.info(),
        "rendering": ref.rendering,
        "scene": ref.scene,
        "scan_stride_px": list(ref.stride),
        "guide_shape": list(result.guide_image.shape[:2]),
    }
    q = result.registration.quality
    return publish_derived(
        bundle,
        stage="guide",
        rig=result.rig_description,
        models={"guide_to_slm": result.homography, "guide_info": info},
        checks=result.checks,
        residuals={
            "guide_reprojection_rms_px": q.rms_px,
            "guide_matches": q.matches,
            "guide_inliers": q.inliers,
        },
        procedure={"guide_registration": result.procedure},
        inputs=[
            {"id": s.id, "sha256": s.sha256(), "kind": "session"}
            for s in (ref.session, result.guide_session)
        ],
        reports={f"{name}.png": png for name, png in result.figures.items()},
        allow_failed=allow_failed,
        data=data,
    )
