"""The guide registration: scan -> RGB on the SLM grid -> SIFT homography -> bundle, as
named steps.

:data:`STEPS` lists them in order (:func:`run_guide_registration` runs them): ``check``;
``scan`` scans a textured scene with pinholes (by default the coarse route: every 4th
horizontal offset of the Nyquist grid, a quarter of the frames) and renders the cube as
RGB on the SLM grid; ``guide`` captures the guide image of the same scene (averaged,
dark-subtracted); ``register`` fits the guide -> SLM homography and grades it against the
procedure's tolerances; ``figures`` and ``publish`` make the report's figures and a new
bundle version (the reductions: :mod:`~sassi_bench.reduce.guide`). It uses device handles
and the rig description only.

A finished rendering (:class:`~sassi_bench.reduce.guide.SlmReference`) can be passed back
in to register a moved guide camera again without a new scan.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.plan_geometry import planned_guide
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import coarse_scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.derive import check_parent
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.guide import (
    GuideRegistration,
    SlmReference,
    guide_image,
    publish_guide,
    register,
    render_figures,
    slm_reference,
)
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan import capture_scan
from sassi_bench.workflows.steps import run_steps

__all__ = [
    "GuideRegistration",
    "SlmReference",
    "capture_guide",
    "publish_guide",
    "run_guide_registration",
    "scan_reference",
]

STEP = "guide registration"


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
    Not run here (it drives a bench and stores its frames)::

        ref = scan_reference(rig, bundle, load_procedure("guide_registration"),
                             session_id="guide-scan")
        ref.image.shape == (*rig.slm.shape, 3)
        # True
    """
    procedure = planned_guide(procedure, rig.description)  # null spacings from the optics
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
    # worth its CPU here (see ``spectra/unmixing.py``).
    scan = capture_scan(rig, session, bundle, unmixing="separable", progress=progress)
    return slm_reference(scan, session, bundle, procedure, rig.description, stride)


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
    Not run here (it drives a bench and stores its frames)::

        image, valid, session = capture_guide(rig, load_procedure("guide_registration"),
                                              session_id="guide-capture")
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
    image, valid = guide_image(session, rig.guide_camera.bit_depth)
    return image, valid, session


@dataclass
class GuideRun:
    """The state of a guide registration as its steps run: the devices, the parent bundle,
    the procedure and the run's settings; then the rendering, the guide image and its
    session, and the registration (its ``bundle_path`` once published)."""

    rig: Rig
    bundle: CalibrationBundle
    procedure: dict[str, Any]
    base: str
    data: str | os.PathLike[str] | None = None
    progress: bool = True
    publish: bool = True
    allow_failed: bool = False
    reference: SlmReference | None = None
    guide: NDArray[np.float64] | None = None
    guide_valid: NDArray[np.bool_] | None = None
    guide_session: Session | None = None
    result: GuideRegistration | None = None


def check(run: GuideRun) -> None:
    """Refuse a bundle of another SLM, a parent published with an override (when
    publishing, unless ``allow_failed``) and a reference rendering of another scene."""
    rig, bundle, proc = run.rig, run.bundle, run.procedure
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                STEP,
                f"bundle is for a {bundle.slm_shape} SLM, the rig has {rig.slm.shape}",
                "load this rig's bundle",
            )
        )
    if run.publish:
        check_parent(bundle, "guide", allow_failed=run.allow_failed)
    if run.reference is not None and run.reference.scene != proc["scene"]:
        raise ProcedureError(
            step_error(
                STEP,
                f"the reference rendering shows scene {run.reference.scene!r}, the procedure "
                f"asks for {proc['scene']!r}",
                "register against a reference of the same scene, or scan again",
            )
        )


def scan(run: GuideRun) -> None:
    """Scan the scene and render it on the SLM grid (:func:`scan_reference`), unless a
    reference rendering was given."""
    if run.reference is None:
        run.reference = scan_reference(
            run.rig, run.bundle, run.procedure, session_id=f"{run.base}-scan", data=run.data,
            progress=run.progress,
        )  # fmt: skip


def guide(run: GuideRun) -> None:
    """The guide image of the scene (:func:`capture_guide`)."""
    run.guide, run.guide_valid, run.guide_session = capture_guide(
        run.rig, run.procedure, session_id=f"{run.base}-guide", data=run.data,
        progress=run.progress,
    )  # fmt: skip


def registration(run: GuideRun) -> None:
    """The guide -> SLM homography, graded."""
    run.result = register(
        run.guide, run.guide_valid, run.guide_session, run.reference, run.procedure,
        run.rig.description,
    )  # fmt: skip


def figures(run: GuideRun) -> None:
    """The match and checkerboard figures (kept in the bundle's ``report/``)."""
    render_figures(run.result)


def publish(run: GuideRun) -> None:
    """Publish the parent's models and the homography as a new bundle version."""
    run.result.bundle_path = publish_guide(
        run.result, run.bundle, data=run.data, allow_failed=run.allow_failed
    )


#: The guide registration's steps, in order.
STEPS = {
    "check": check,
    "scan": scan,
    "guide": guide,
    "register": registration,
    "figures": figures,
    "publish": publish,
}


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
        Publish a bundle (the ``publish`` step); refuse one that failed its checks, or a
        ``bundle`` published with an override (checked before the scan), unless
        ``allow_failed``.

    Returns
    -------
    GuideRegistration

    Raises
    ------
    RegistrationError
        Too few matches or too little coverage (with advice on the target to use).

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        result = run_guide_registration(rig, bundle, load_procedure("guide_registration"))
        result.registration.quality.rms_px
        # 0.69
    """
    proc = planned_guide(
        {k: v for k, v in dict(procedure).items() if k != "source"}, rig.description
    )
    run = GuideRun(
        rig, bundle, proc, session_id or _stamp(), data, progress, publish_bundle, allow_failed,
        reference,
    )  # fmt: skip
    steps = [name for name in STEPS if publish_bundle or name != "publish"]
    return run_steps(STEPS, run, steps, procedure=STEP).result
