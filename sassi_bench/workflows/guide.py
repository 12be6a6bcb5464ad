"""The guide registration workflow: scan -> RGB on the SLM grid -> SIFT homography -> bundle.

:func:`run_guide_registration` scans a textured scene with pinholes (by default the coarse
route: every 4th horizontal offset of the Nyquist grid, a quarter of the frames), renders
the cube as RGB on the SLM grid, captures the guide image of the same scene (averaged,
dark-subtracted), fits the guide -> SLM homography
(:func:`~sassi_bench.calibrate.guide_registration.register_guide`), grades it against
the procedure's tolerances and publishes a new bundle version: the given bundle's models
plus the homography and its quality. It uses device handles and the rig description only.

A finished rendering (:class:`SlmReference`) can be passed back in to register a moved
guide camera again without a new scan.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import coarse_scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle, QualityCheck, publish_derived
from sassi_bench.bundle.derive import check_parent
from sassi_bench.calibrate.guide_registration import Registration, register_guide
from sassi_bench.calibrate.guide_render import (
    render_rgb,
    rendering_sensitivities,
    upsample_lattice,
)
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan_feed import capture_scan

__all__ = [
    "GuideRegistration",
    "SlmReference",
    "capture_guide",
    "publish_guide",
    "run_guide_registration",
    "scan_reference",
]

STEP = "guide registration"


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


def _stamp() -> str:
    return "guide-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def _check_resumed(session: Session, expected: Mapping[str, Any]) -> None:
    """A resumed session must have been planned with the procedure's parameters."""
    stored = session.plan.parameters
    differ = {k: v for k, v in expected.items() if _plain(stored.get(k)) != _plain(v)}
    if differ:
        raise ProcedureError(
            step_error(
                STEP,
                f"session {session.id!r} was planned with "
                + ", ".join(f"{k}={_plain(stored.get(k))}" for k in differ)
                + ", the procedure asks for "
                + ", ".join(f"{k}={_plain(v)}" for k, v in differ.items()),
                "use a new --session id, or the procedure the session was made with",
            )
        )


def _plain(value: Any) -> Any:
    return [_plain(v) for v in value] if isinstance(value, list | tuple) else value


@drives_rig("guide registration")
def scan_reference(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    session_id: str,
    data=None,
    progress: bool = True,
) -> SlmReference:
    """Scan the procedure's scene (coarse or full) and render it as RGB on the SLM grid.

    Parameters
    ----------
    rig
        Device handles.
    bundle
        The calibration bundle the scan is assembled with.
    procedure
        The guide-registration procedure: its ``scene``, ``light``, ``scan`` and
        ``rendering`` sections.
    session_id
        Id of the raw scan session; an existing id resumes.
    data
        Data root for sessions.
    progress
        Show progress bars.

    Returns
    -------
    SlmReference
        The rendering (radiance if the bundle has a response), where it is measured, and
        the scan session.

    Examples
    --------
    >>> ref = scan_reference(rig, bundle, load_procedure("guide_registration"),
    ...                      session_id="guide-scan")  # doctest: +SKIP
    >>> ref.image.shape == (*rig.slm.shape, 3)  # doctest: +SKIP
    True
    """
    scan_cfg = procedure["scan"]
    pitch = tuple(int(p) for p in scan_cfg["pitch_px"])
    stride = (int(scan_cfg["stride_px"][0]), int(scan_cfg["stride_px"][1]))
    scene, light = str(procedure["scene"]), str(procedure["light"])

    def make_plan() -> Plan:
        rig.set_scene(scene)
        exposure = auto_exposure(
            rig,
            light,
            {"kind": "pinholes", "pitch": list(pitch)},
            target_fraction=float(scan_cfg["target_fraction"]),
        )
        return coarse_scan_plan(rig.slm.shape, light, exposure, pitch, stride, scene)

    session = Session.resume_or_plan(rig.description, make_plan, session_id=session_id, data=data)
    _check_resumed(
        session, {"scene": scene, "light": light, "pitch": list(pitch), "stride": list(stride)}
    )
    # Rendered to RGB for features only: the mixed row unmixing's red-end radiometry is not
    # worth its CPU here (about 7 s of 22 at the prototype's size).
    scan = capture_scan(rig, session, bundle, row_mixture=False, progress=progress)
    cube = scan.cube[:: stride[1], :: stride[0]]
    if bundle.response is not None:
        cube = cube / np.asarray(bundle.response, dtype=np.float32)
    valid = scan.quality[:: stride[1], :: stride[0]] == 0
    sensitivities, label = rendering_sensitivities(
        rig.description.guide_camera.sensitivities, str(procedure["rendering"]), scan.wavelengths_nm
    )
    rgb = render_rgb(cube, scan.wavelengths_nm, sensitivities=sensitivities, valid=valid)
    image, image_valid = upsample_lattice(rgb, valid, stride, rig.slm.shape)
    return SlmReference(np.clip(image, 0.0, 1.0), image_valid, label, scene, session, stride)


@drives_rig("guide registration")
def capture_guide(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str,
    data=None,
    progress: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], Session]:
    """Averaged, dark-subtracted guide image of the procedure's scene, and unsaturated pixels.

    Parameters
    ----------
    rig
        Device handles.
    procedure
        The guide-registration procedure: its ``scene``, ``light`` and ``guide`` sections
        (frames to average, exposure target).
    session_id
        Id of the raw guide session; an existing id resumes.
    data
        Data root for sessions.
    progress
        Show a progress bar.

    Returns
    -------
    image : ndarray
        float64, lit minus dark frames, each averaged.
    valid : ndarray
        bool (H, W), pixels no lit frame saturated.
    session : Session
        The guide session.

    Examples
    --------
    >>> image, valid, session = capture_guide(rig, load_procedure("guide_registration"),
    ...                                       session_id="guide-capture")  # doctest: +SKIP
    """
    cfg = procedure["guide"]
    scene, light = str(procedure["scene"]), str(procedure["light"])
    blank = {"kind": "blank"}

    def make_plan() -> Plan:
        rig.set_scene(scene)
        target = float(cfg["target_fraction"])
        exposure = auto_exposure(rig, light, blank, camera="guide", target_fraction=target)
        n = int(cfg["frames"])
        steps = [Step("guide", light, exposure, blank, {"role": "guide"}) for _ in range(n)]
        steps += [Step("guide", "off", exposure, blank, {"role": "guide_dark"}) for _ in range(n)]
        return Plan("guide-capture", tuple(steps), {"scene": scene, "light": light})

    session = Session.resume_or_plan(rig.description, make_plan, session_id=session_id, data=data)
    _check_resumed(session, {"scene": scene, "light": light})
    run_plan(rig, session.plan, session, progress=progress)
    lit = session.read_frames(session.plan.select(role="guide")).astype(np.float64)
    dark = session.read_frames(session.plan.select(role="guide_dark")).astype(np.float64)
    saturation = 2**rig.guide_camera.bit_depth - 1
    valid = np.all(lit < saturation, axis=(0, -1)) if lit.ndim == 4 else np.all(lit < saturation, 0)
    return lit.mean(axis=0) - dark.mean(axis=0), valid, session


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


@drives_rig("guide registration")
def run_guide_registration(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    reference: SlmReference | None = None,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
    publish_bundle: bool = True,
    allow_failed: bool = False,
    figures: bool = True,
) -> GuideRegistration:
    """Register the guide camera to the SLM and publish the homography in a new bundle.

    Parameters
    ----------
    rig
        Device handles (virtual or real).
    bundle
        The rig's latest calibration bundle (streak geometry for the scan; its models are
        carried into the new version).
    procedure
        A validated guide-registration procedure
        (``load_procedure("guide_registration")``).
    reference
        A rendering from an earlier run (``result.reference``): skip the scan, capture
        only a new guide image (after the guide camera moved).
    session_id
        Base id of the raw sessions (``<id>-scan``, ``<id>-guide``); an existing id resumes.
    data
        Data root for sessions and bundles.
    publish_bundle, allow_failed
        Publish a bundle; refuse one that failed its checks, or a ``bundle`` published
        with an override (checked before the scan), unless ``allow_failed``.
    figures
        Make the match and checkerboard figures (kept in the bundle's ``report/``).

    Returns
    -------
    GuideRegistration

    Raises
    ------
    RegistrationError
        Too few matches or too little coverage (with advice on the target to use).

    Examples
    --------
    >>> result = run_guide_registration(rig, bundle, load_procedure("guide_registration"))
    ... # doctest: +SKIP
    >>> result.registration.quality.rms_px  # doctest: +SKIP
    0.69
    """
    proc = {k: v for k, v in dict(procedure).items() if k != "source"}
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                STEP,
                f"bundle is for a {bundle.slm_shape} SLM, the rig has {rig.slm.shape}",
                "load this rig's bundle",
            )
        )
    if publish_bundle:
        check_parent(bundle, "guide", allow_failed=allow_failed)
    base = session_id or _stamp()
    if reference is None:
        reference = scan_reference(
            rig, bundle, proc, session_id=f"{base}-scan", data=data, progress=progress
        )
    elif reference.scene != proc["scene"]:
        raise ProcedureError(
            step_error(
                STEP,
                f"the reference rendering shows scene {reference.scene!r}, the procedure "
                f"asks for {proc['scene']!r}",
                "register against a reference of the same scene, or scan again",
            )
        )
    guide, guide_valid, guide_session = capture_guide(
        rig, proc, session_id=f"{base}-guide", data=data, progress=progress
    )
    match, tol = proc["match"], proc["tolerances"]
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
    result = GuideRegistration(
        proc,
        rig.description,
        registration,
        reference,
        guide,
        guide_valid,
        guide_session,
        _checks(registration, tol),
    )
    if figures:
        from sassi_bench.plots.guide import guide_figures
        from sassi_bench.plots.png import figure_png

        result.figures = {name: figure_png(fig) for name, fig in guide_figures(result).items()}
    if publish_bundle:
        result.bundle_path = publish_guide(result, bundle, data=data, allow_failed=allow_failed)
    return result


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
    >>> path = publish_guide(result, bundle)  # doctest: +SKIP
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
