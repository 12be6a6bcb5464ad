"""One capture for the SASSI authors' reconstruction code: ``adaptive_cassi.mat``.

``cassi.py``'s ``__main__`` (Image-Science-Lab-cmu/SASSI, ``modules/cassi.py``) reads,
besides the calibration files of :mod:`sassi_bench.export.sassi_mat`, one file per
capture with:

``lcos_mask``
    The SLM pattern, ``(Hl, Wl)`` uint8, 0 or 255, the SLM's own orientation
    (``[row, column]``). Read as ``astype(float32) / 255``: ``get_cassi_img`` uses the
    values as the cube, ``_get_cassi_cube`` samples where ``mask > 0``, and ``slic_update``
    seeds superpixels where ``mask == 1``, so grey levels would be misread; patterns
    with levels other than 0 and 255 are refused. Its shape must be the shape of ``Xl``.
``cassi_img``
    The raw spectral-camera frame ``(Hc, Wc)`` as captured (uint16; read with
    ``astype(float32)``). No dark or offset subtraction: ``get_cassi_cube`` estimates the
    background from streak-free pixels itself.
``guide_img_rec``
    The guide (RGB) frame warped onto the SLM grid with the bundle's homography
    (:meth:`CalibrationBundle.warp_guide_to_slm`) and cropped to ``limits``:
    ``(h2 - h1, w2 - w1, 3)`` uint8, RGB order (``slic_update`` converts it with
    ``cv2.COLOR_RGB2Lab``, ``__main__`` uses ``mean(2) / 255`` as the panchromatic guide).
    The averaged (optionally dark-subtracted) guide frames are scaled linearly so that
    the 99.9th percentile of the crop maps to 255 (``guide_white_level`` records it).
``vsize``
    int32 ``(1, 1)``: the row window to pass to ``get_cassi_cube`` for this capture,
    chosen by running the authors' own extraction on this frame
    (:mod:`sassi_bench.export.window_choice`) unless given.
``limits``
    ``[h1, h2, w1, w2]`` int32, used as Python slice bounds ``mask[h1:h2, w1:w2]``
    (0-based, end exclusive; no 1 is subtracted). ``__main__`` passes the *uncropped*
    cube from ``get_cassi_cube`` together with the cropped mask and guide to
    ``recon_superpixel``, whose compiled loop indexes all three with the cube's shape:
    it runs only when the limits span the whole SLM, which is the default here. With
    other limits, crop the cube (``cube[h1:h2, w1:w2]``) before ``recon_superpixel``.

The frame and its pattern come from a raw session: each step stores the JSON
descriptor of what the SLM showed, and the mask is rebuilt with
:func:`sassi_bench.acquire.patterns.render_pattern`, so any pattern kind that function
knows (an arbitrary mask included) exports without changes here.

Examples
--------
Not run here (it needs captured frames or the authors' code)::

    from sassi_bench.acquire.session import Session
    session = Session.open("my-snapshot")
    export_adaptive_cassi(bundle, session, step=0, guide_steps=[1], out="exp1")
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_dtype_kind, check_shape
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.export.matfile import write_mat
from sassi_bench.export.sassi_mat import camera_shape_of, sassi_tables, suggested_ksizes
from sassi_bench.export.window_choice import VsizeChoice, choose_vsize
from sassi_bench.rig.config import rig_dict_sha256

__all__ = [
    "ADAPTIVE_CASSI_FILE",
    "AdaptiveCassiExport",
    "capture_vsize",
    "check_vsize",
    "export_adaptive_cassi",
    "guide_to_uint8",
    "lcos_mask",
    "select_steps",
]

ADAPTIVE_CASSI_FILE = "adaptive_cassi.mat"
#: The percentile of the guide crop that is mapped to 255.
GUIDE_WHITE_PERCENTILE = 99.9


@dataclass(frozen=True)
class AdaptiveCassiExport:
    """What :func:`export_adaptive_cassi` wrote.

    Attributes
    ----------
    path
        The ``adaptive_cassi.mat`` file.
    limits
        ``(h1, h2, w1, w2)``.
    open_pixels
        Number of open SLM pixels in ``lcos_mask``.
    vsize
        The row window written.
    vsize_choice
        How it was chosen (None when it was given).
    notes
        Things the user should know (e.g. the session's rig differs from the bundle's).
    """

    path: Path
    limits: tuple[int, int, int, int]
    open_pixels: int
    vsize: int
    vsize_choice: VsizeChoice | None = None
    notes: tuple[str, ...] = field(default=())


def _fail(cause: str, fix: str) -> ProcedureError:
    return ProcedureError(step_error("snapshot export", cause, fix))


def select_steps(
    session: Session,
    camera: str,
    *,
    step: int | None = None,
    tags: Mapping[str, Any] | None = None,
) -> list[int]:
    """Captured steps of ``camera`` in ``session``, chosen by index or by tags.

    Parameters
    ----------
    session
        The raw session.
    camera
        ``"spectral"`` or ``"guide"``.
    step
        One plan step index.
    tags
        Tags every chosen step must carry (``Plan.select``); used when ``step`` is None.

    Returns
    -------
    list of int
        Step indices in plan order (at least one).

    Raises
    ------
    ProcedureError
        If nothing (or a step of another camera, or an uncaptured step) matches.

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        select_steps(session, "guide", tags={"role": "guide"})
        # [1]
    """
    plan = session.plan
    if step is not None:
        if not 0 <= int(step) < len(plan):
            raise _fail(
                f"session {session.id!r} has no step {step} (plan of {len(plan)} steps)",
                f"pass a step index 0..{len(plan) - 1}",
            )
        chosen = [int(step)]
    elif tags:
        chosen = plan.select(**dict(tags))
    else:
        raise _fail(f"no {camera} frame was chosen", "pass a step index or tags")
    captured = [i for i in chosen if plan.steps[i].camera == camera and i in session.completed]
    if not captured:
        available = [i for i in sorted(session.completed) if plan.steps[i].camera == camera]
        described = ", ".join(f"{i} {dict(plan.steps[i].tags)}" for i in available[:8])
        raise _fail(
            f"no captured {camera} frame of session {session.id!r} matches "
            f"{'step ' + str(step) if step is not None else dict(tags or {})}",
            f"choose one of the captured {camera} steps: {described or 'none'}",
        )
    return captured


def lcos_mask(descriptor: Mapping[str, Any], slm_shape: tuple[int, int]) -> NDArray[np.uint8]:
    """The pattern a step showed, as the authors' ``lcos_mask``: uint8, 0 or 255.

    Raises
    ------
    ProcedureError
        If the pattern has grey levels other than 0 and 255.

    Examples
    --------
    >>> lcos_mask({"kind": "pinholes", "pitch": [3, 2]}, (2, 6)).tolist()
    [[255, 0, 0, 255, 0, 0], [0, 0, 0, 0, 0, 0]]
    """
    mask = render_pattern(descriptor, slm_shape)
    levels = np.unique(mask)
    if not np.isin(levels, (0, 255)).all():
        raise _fail(
            f"the step's pattern {dict(descriptor)} has grey levels "
            f"{levels[(levels != 0) & (levels != 255)][:5].tolist()}",
            "export a binary (0/255) pattern; cassi.py reads lcos_mask / 255 as a 0/1 mask",
        )
    return mask


def guide_to_uint8(image: ArrayLike) -> tuple[NDArray[np.uint8], float]:
    """Scale an RGB image linearly so its 99.9th percentile becomes 255 (uint8).

    Returns
    -------
    image : ndarray
        uint8, same shape.
    white : float
        The input level mapped to 255.

    Examples
    --------
    >>> out, white = guide_to_uint8(np.linspace(0, 1000, 12).reshape(2, 2, 3))
    >>> int(out.max()), round(white)
    (255, 999)
    """
    data = np.asarray(image, dtype=np.float64)
    white = float(np.percentile(data, GUIDE_WHITE_PERCENTILE))
    if not white > 0:
        raise _fail(
            "the guide image is dark (its 99.9th percentile is not above 0)",
            "pair the snapshot with a guide frame of the lit scene",
        )
    return np.clip(np.rint(data * (255.0 / white)), 0, 255).astype(np.uint8), white


def _limits(limits: Sequence[int] | None, slm_shape: tuple[int, int]) -> tuple[int, ...]:
    height, width = slm_shape
    if limits is None:
        return (0, height, 0, width)
    values = tuple(int(v) for v in limits)
    if len(values) != 4:
        raise _fail(f"limits {limits} are not 4 numbers", "pass h1 h2 w1 w2")
    h1, h2, w1, w2 = values
    if not (0 <= h1 < h2 <= height and 0 <= w1 < w2 <= width):
        raise _fail(
            f"limits {values} are not a crop of the {height} x {width} SLM",
            f"pass 0 <= h1 < h2 <= {height} and 0 <= w1 < w2 <= {width} (Python slice bounds)",
        )
    return values


def capture_vsize(
    bundle: CalibrationBundle,
    frame: ArrayLike,
    mask: ArrayLike,
    exposure_s: float,
) -> VsizeChoice:
    """The row window for the authors' ``get_cassi_cube`` on this frame, chosen by their
    own extraction against this package's spectra of the same frame.

    Parameters
    ----------
    bundle
        The calibration bundle the capture is exported with.
    frame
        The raw spectral frame.
    mask
        The SLM pattern shown (nonzero: open).
    exposure_s
        The frame's exposure.

    Returns
    -------
    VsizeChoice

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        capture_vsize(bundle, frame, mask, 0.01).vsize
        # 9
    """
    from sassi_bench.snapshot.reconstruct import measure_samples

    pattern = np.asarray(mask) > 0
    if not pattern.any():
        raise _fail("the pattern opens no SLM pixel", "export a frame of a snapshot mask")
    spectra, _ = measure_samples(frame, pattern, bundle, exposure_s=exposure_s)
    if bundle.response is not None:  # back to camera units, as the authors' cube is
        spectra = spectra * np.asarray(bundle.response)
    sigma = np.asarray(bundle.blur_width(bundle.wavelengths), dtype=np.float64)
    return choose_vsize(
        sassi_tables(bundle), frame, pattern.astype(np.float32), spectra,
        suggested_ksizes(sigma), sigma_px=sigma,
    )  # fmt: skip


def check_vsize(vsize: int) -> int:
    """``vsize`` as a positive odd int, else a :class:`ProcedureError`.

    An even window is refused: ``convolve2d(..., 'same')`` with an even kernel sums rows
    ``r - vsize/2 .. r + vsize/2 - 1``, half a row off the streak.

    Examples
    --------
    >>> check_vsize(5)
    5
    """
    if int(vsize) != vsize or vsize < 1 or vsize % 2 == 0:
        raise _fail(
            f"vsize {vsize} is not a positive odd number of rows",
            "pass an odd window (1, 3, 5, ...), or leave it out to let the authors' "
            "extraction choose it on the frame",
        )
    return int(vsize)


def _mean_frame(session: Session, steps: Sequence[int]) -> NDArray[np.float64]:
    return np.mean([session.read_frame(i).astype(np.float64) for i in steps], axis=0)


def export_adaptive_cassi(
    bundle: CalibrationBundle,
    session: Session,
    step: int,
    out: str | os.PathLike[str],
    *,
    guide_steps: Sequence[int],
    guide_session: Session | None = None,
    guide_dark_steps: Sequence[int] = (),
    limits: Sequence[int] | None = None,
    vsize: int | None = None,
) -> AdaptiveCassiExport:
    """Write ``<out>/adaptive_cassi.mat`` from a spectral frame, its mask and guide frames.

    Parameters
    ----------
    bundle
        Calibration bundle (SLM and camera shapes, guide -> SLM homography).
    session
        Raw session holding the spectral frame (and, by default, the guide frames).
    step
        Plan step index of the spectral frame.
    out
        Folder of the capture (cassi.py reads ``<root>/<experiment>/adaptive_cassi.mat``).
    guide_steps
        Guide frames to average into ``guide_img_rec`` (at least one).
    guide_session
        Session holding the guide frames (default: ``session``).
    guide_dark_steps
        Guide frames with the light off, averaged and subtracted (optional).
    limits
        ``(h1, h2, w1, w2)`` crop of the SLM (default: the whole SLM; see the module
        docstring for why).
    vsize
        The row window to write (odd); default: chosen by :func:`capture_vsize`, which
        needs PyTorch (``sassi-bench[sassi]``).

    Returns
    -------
    AdaptiveCassiExport

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        export_adaptive_cassi(bundle, session, 0, "exp1", guide_steps=[1])
    """
    target = Path(out) / ADAPTIVE_CASSI_FILE
    if target.exists():  # checked before the window is chosen, which takes a while
        raise _fail(
            f"{target} already exists (exports are never overwritten)",
            "choose a new output folder",
        )
    if vsize is not None:
        check_vsize(vsize)
    guide_session = session if guide_session is None else guide_session
    spectral = select_steps(session, "spectral", step=step)[0]
    guides = [select_steps(guide_session, "guide", step=i)[0] for i in guide_steps]
    darks = [select_steps(guide_session, "guide", step=i)[0] for i in guide_dark_steps]
    if not guides:
        raise _fail("no guide frame was chosen", "pass at least one guide step")
    slm_shape = bundle.slm_shape
    notes = []
    rig = session.rig
    session_slm = (int(rig["slm"]["height"]), int(rig["slm"]["width"]))
    if session_slm != slm_shape:
        raise _fail(
            f"session {session.id!r} was captured with a {session_slm} SLM, the bundle "
            f"calibrates a {slm_shape} one",
            "export with a bundle of the rig the session was captured on",
        )
    # As sessions hash a rig: where its hardware is plugged in is left out.
    if session.rig_sha256 != rig_dict_sha256(thaw(bundle.manifest["rig"])):
        notes.append(
            f"session {session.id!r} was captured on a rig description that differs from "
            f"the one bundle {bundle.rig_name}/{bundle.version} was calibrated on; check "
            "that the optics did not change"
        )
    frame = session.read_frame(spectral)
    camera_shape = camera_shape_of(bundle)
    check_shape(
        frame,
        camera_shape,
        step="snapshot export",
        name=f"the frame of step {spectral}",
        expected_for="the bundle's camera",
        fix="export with a bundle of the rig the session was captured on",
    )
    check_dtype_kind(
        frame,
        "ui",
        step="snapshot export",
        name=f"the frame of step {spectral}",
        fix="export a raw camera frame",
    )
    mask = lcos_mask(session.event(spectral)["pattern"], slm_shape)
    crop = _limits(limits, slm_shape)
    choice = None
    if vsize is None:
        choice = capture_vsize(bundle, frame, mask, session.plan.steps[spectral].exposure_s)
        window = choice.vsize
    else:
        window = check_vsize(vsize)
    h1, h2, w1, w2 = crop
    guide = _mean_frame(guide_session, guides)
    if darks:
        guide = guide - _mean_frame(guide_session, darks)
    warped = bundle.warp_guide_to_slm(guide.astype(np.float32))[h1:h2, w1:w2]
    guide_rec, white = guide_to_uint8(warped)
    path = write_mat(
        target,
        {
            "lcos_mask": mask,
            "cassi_img": np.asarray(frame),
            "guide_img_rec": guide_rec,
            "vsize": np.array([[window]], dtype=np.int32),
            "limits": np.array(crop, dtype=np.int32),
            "guide_white_level": white,
            "session_id": session.id,
            "spectral_step": np.int32(spectral),
            "guide_steps": np.array(guides, dtype=np.int32),
            "bundle_version": f"{bundle.rig_name}/{bundle.version}",
        },
    )
    return AdaptiveCassiExport(path, crop, int((mask > 0).sum()), window, choice, tuple(notes))
