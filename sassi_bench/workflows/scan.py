"""Pinhole-scan workflows: the radiometric response and reference cubes.

:func:`run_response` scans a white diffuser under a source of known spectrum (halogen as
a blackbody of the rig's lamp temperature, or a reference CSV) and publishes a new
bundle version with the per-bin response. :func:`run_scan` scans a scene, assembles the
cube with a bundle and divides by its response when it has one.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.scan_plans import check_pitch, check_roi, scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.streak_pitch import check_scan_pitch
from sassi_bench.bundle import CalibrationBundle, QualityCheck, publish_derived
from sassi_bench.bundle.derive import check_parent
from sassi_bench.calibrate.radiometry import (
    read_reference_csv,
    response_from_white,
    source_photons_in_bins,
    temperature_sensitivity,
)
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.scan import ScanRun
from sassi_bench.rig.rig import Rig, check_light, check_scene
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.scan_deblur import scan_mean_spectrum
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan_feed import capture_scan

__all__ = ["ResponseSource", "check_scan", "response_source", "run_response", "run_scan"]


def _stamp(prefix: str) -> str:
    return f"{prefix}-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def check_scan(
    rig: Rig,
    scene: str,
    light: str,
    pitch: tuple[int, int],
    roi: Sequence[int] | None = None,
) -> None:
    """Refuse a scan the rig cannot take (scene, light, pitch, ROI), before any capture.

    Parameters
    ----------
    rig
        Device handles.
    scene
        The scene to scan (a virtual bench's scene name).
    light
        One of the rig's lights.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels.
    roi
        Part of the SLM to assemble, or None for all of it.

    Raises
    ------
    ProcedureError
        Naming the first argument the rig cannot take, and the choices it has; or a
        pitch at which the streaks leave no streak-free camera columns
        (:func:`~sassi_bench.acquire.streak_pitch.check_scan_pitch`).

    Examples
    --------
    >>> check_scan(open_rig("sim"), "colorchecker", "led", (100, 5))  # doctest: +SKIP
    """
    check_scene(scene, step="scan")
    check_light(light, rig.light.available, step="scan")
    check_pitch(pitch, rig.slm.shape)
    check_scan_pitch(rig.description, pitch)
    check_roi(roi, rig.slm.shape, step="scan")


#: The lamp temperature uncertainty whose effect on the response is reported (K).
LAMP_DELTA_K = 100.0


@dataclass(frozen=True)
class ResponseSource:
    """The spectrum of the source a response scan is taken under: a reference spectrum
    (wavelengths in nm, relative power) or a blackbody temperature."""

    temperature_k: float | None
    reference: tuple[np.ndarray, np.ndarray] | None
    label: str

    def photons_in_bins(self, bin_edges_nm) -> np.ndarray:
        """Relative photon flux per bin (:func:`source_photons_in_bins`).

        Parameters
        ----------
        bin_edges_nm
            (B + 1,) edges of the wavelength bins.

        Returns
        -------
        ndarray
            (B,) photon flux of the source in each bin, relative.

        Examples
        --------
        >>> flux = ResponseSource(3000.0, None, "blackbody 3000 K").photons_in_bins([400, 550, 700])
        >>> bool(flux[1] > flux[0])  # a halogen lamp is redder than it is blue
        True
        """
        return source_photons_in_bins(
            bin_edges_nm, temperature_k=self.temperature_k, reference=self.reference
        )

    def temperature_sensitivity(
        self, bin_edges_nm, delta_k: float = LAMP_DELTA_K
    ) -> dict[str, Any] | None:
        """How much a response taken under this blackbody changes, per bin, if the lamp
        is ``delta_k`` cooler or hotter than assumed (None for a reference spectrum,
        whose uncertainty is the lab's to state).

        Parameters
        ----------
        bin_edges_nm
            (B + 1,) edges of the wavelength bins.
        delta_k
            The lamp temperature uncertainty (K).

        Returns
        -------
        dict or None
            The temperature, ``delta_k``, the largest relative change over bins and the
            relative change per bin for a cooler and a hotter lamp.

        Examples
        --------
        >>> source = ResponseSource(3000.0, None, "blackbody 3000 K")
        >>> round(source.temperature_sensitivity([400, 550, 700])["max_relative_change"], 3)
        0.037
        """
        if self.temperature_k is None:
            return None
        change = temperature_sensitivity(bin_edges_nm, self.temperature_k, delta_k)
        return {
            "temperature_k": self.temperature_k,
            "delta_k": float(delta_k),
            "max_relative_change": float(np.abs(change).max()),
            "relative_change_cooler": change[0].tolist(),
            "relative_change_hotter": change[1].tolist(),
        }


def response_source(
    rig: Rig,
    temperature_k: float | None = None,
    reference_csv: str | os.PathLike[str] | None = None,
) -> ResponseSource:
    """The source of a response scan: a reference CSV, else a blackbody at ``temperature_k``
    or the rig's ``light.halogen_k``; refused before any capture when none is known.

    Parameters
    ----------
    rig
        Device handles (their description's ``light.halogen_k``).
    temperature_k
        Colour temperature of the lamp (1000-10000 K).
    reference_csv
        A CSV of ``wavelength_nm,power``; wins over a temperature.

    Returns
    -------
    ResponseSource
        The spectrum and a label for the bundle's provenance.

    Raises
    ------
    ProcedureError
        If no source spectrum is known, or the temperature is no lamp's.

    Examples
    --------
    >>> response_source(open_rig("sim"), temperature_k=3100).label  # doctest: +SKIP
    'blackbody 3100 K'
    """
    if reference_csv is not None:
        return ResponseSource(None, read_reference_csv(reference_csv), str(reference_csv))
    kelvin = temperature_k if temperature_k is not None else rig.description.light.halogen_k
    if kelvin is None:
        raise ProcedureError(
            step_error(
                "radiometric response",
                f"rig {rig.description.name!r} does not give its halogen lamp's colour "
                "temperature (light.halogen_k) and no source spectrum was given",
                "pass --temperature K or --reference CSV, or set light.halogen_k in the rig",
            )
        )
    if not 1000 <= kelvin <= 10000:
        raise ProcedureError(
            step_error(
                "radiometric response",
                f"a blackbody of {kelvin:g} K is no lamp",
                "give the colour temperature in kelvin (1000-10000; halogen: about 3000)",
            )
        )
    return ResponseSource(float(kelvin), None, f"blackbody {kelvin:g} K")


def _plan(rig: Rig, scene: str, light: str, pitch, every: int, target: float) -> Plan:
    rig.set_scene(scene)
    # One pinhole frame samples every 100th column and can miss the brightest part of
    # the scene (the chart's white patch), which then saturates later in the scan; so
    # expose for the brightest of five frames spread over the column pitch.
    exposure = None
    for dx in range(0, pitch[0], max(1, pitch[0] // 5)):
        pattern = {"kind": "pinholes", "pitch": list(pitch), "offset": [dx, 0]}
        found = auto_exposure(rig, light, pattern, target_fraction=target, start_s=exposure or 0.01)
        exposure = found if exposure is None else min(exposure, found)
    plan = scan_plan(rig.slm.shape, light, exposure, tuple(pitch), scene=scene)
    if every > 1:  # a thinned scan: every n-th pinhole offset
        keep = [s for i, s in enumerate(plan.steps) if s.tags["role"] == "closed" or i % every == 1]
        plan = Plan(plan.name, tuple(keep), {**plan.parameters, "every": every})
    return plan


@drives_rig("radiometric response")
def run_response(
    rig: Rig,
    bundle: CalibrationBundle,
    *,
    light: str = "halogen",
    temperature_k: float | None = None,
    reference_csv: str | os.PathLike[str] | None = None,
    reflectance: float = 1.0,
    pitch: tuple[int, int] = (100, 5),
    every: int = 25,
    session_id: str | None = None,
    data=None,
    progress: bool = True,
    allow_failed: bool = False,
) -> Path:
    """Measure the per-bin response on a white diffuser and publish it in a new bundle.

    The source spectrum is a blackbody at ``temperature_k`` (default: the rig's
    ``light.halogen_k``) or a reference CSV (wavelength_nm, power). The new bundle
    carries ``bundle``'s quality checks; a parent published with an override is refused
    (before anything is captured) unless ``allow_failed``.

    Parameters
    ----------
    rig
        Device handles; the white diffuser is put in front.
    bundle
        The bundle the scan is assembled with and the new version derives from.
    light
        The light the diffuser is lit with.
    temperature_k, reference_csv
        The source's spectrum (see :func:`response_source`).
    reflectance
        Reflectance of the diffuser.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels.
    every
        Keep every n-th pinhole offset (a thinned scan is enough for a flat target).
    session_id
        Id of the raw session; an existing id resumes.
    data
        Data root for sessions and bundles.
    progress
        Show progress bars.
    allow_failed
        Publish although a check failed, or derive from a parent published with an
        override.

    Returns
    -------
    pathlib.Path
        The new bundle's folder.

    Examples
    --------
    >>> path = run_response(rig, bundle, temperature_k=3100)  # doctest: +SKIP
    """
    check_parent(bundle, "response", allow_failed=allow_failed)
    check_scan(rig, "white", light, pitch)
    source = response_source(rig, temperature_k, reference_csv)
    session = Session.resume_or_plan(
        rig.description,
        lambda: _plan(rig, "white", light, pitch, every, 0.6),
        session_id=session_id or _stamp("response"),
        data=data,
    )
    scan = capture_scan(rig, session, bundle, keep_raw=True, progress=progress)
    lit = (scan.quality == 0) & (np.abs(scan.cube).sum(axis=-1) > 0)
    spectra = scan.cube[lit]
    # The white's column sums are averaged first and deblurred once, at the mean's noise:
    # noise averages out of a mean, the per-pixel deblur's smoothing bias would not.
    white = scan_mean_spectrum(scan, StreakForwardModel.from_bundle(bundle), lit)
    response = response_from_white(
        white.band, source.photons_in_bins(bundle.bin_edges), reflectance, pixels=white.count
    )
    positive = bool(np.all(np.isfinite(response)) and np.all(response > 0))
    spread = float(np.median(np.std(spectra, axis=0) / np.abs(np.mean(spectra, axis=0))))
    residuals: dict[str, Any] = {"white_relative_spread": spread}
    sensitivity = source.temperature_sensitivity(bundle.bin_edges)
    if sensitivity is not None:
        residuals["lamp_temperature_sensitivity"] = sensitivity
    checks = [
        QualityCheck("response_positive", float(positive), 1.0, "1", positive, ">="),
        QualityCheck.at_most("white_uniformity", spread, 0.1, "1"),
    ]
    return publish_derived(
        bundle,
        stage="response",
        rig=rig.description,
        models={
            "offset": {
                "method": "per-pixel mean of streak-free frames",
                "fallback": "block-median spline",
            },
            "response": response,
        },
        checks=checks,
        residuals=residuals,
        procedure={
            "response": {
                "light": light,
                "pitch": list(pitch),
                "every": every,
                "reflectance": reflectance,
                "source": source.label,
                "deblur": {
                    "mean": white.choice.to_dict(),
                    "pixels": scan.deblur.to_dict() if scan.deblur is not None else None,
                },
            },
        },
        inputs=[{"id": session.id, "sha256": session.sha256(), "kind": "session"}],
        allow_failed=allow_failed,
        data=data,
    )


@drives_rig("scan")
def run_scan(
    rig: Rig,
    bundle: CalibrationBundle,
    *,
    scene: str = "colorchecker",
    light: str = "led",
    pitch: tuple[int, int] = (100, 5),
    roi: Sequence[int] | None = None,
    session_id: str | None = None,
    data=None,
    progress: bool = True,
    keep_raw: bool = False,
) -> ScanRun:
    """Capture (or resume) a pinhole scan of ``scene`` and assemble it with ``bundle``.

    Parameters
    ----------
    rig
        Device handles.
    bundle
        This rig's calibration bundle.
    scene
        The scene to scan.
    light
        The light to scan under.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels.
    roi
        Part of the SLM to assemble, or None for all of it.
    session_id
        Id of the raw session; an existing id resumes.
    data
        Data root for sessions.
    progress
        Show progress bars.
    keep_raw
        Also keep the column sums before the deblur (for spectra averaged first and
        deblurred once: the Macbeth patches).

    Returns
    -------
    ScanRun
        The assembled cube, whether it is radiance (the bundle has a response), the
        session and the bundle.

    Raises
    ------
    ProcedureError
        For a scan the rig cannot take, or a bundle of another SLM.

    Examples
    --------
    >>> run = run_scan(open_rig("sim"), load(rig="sim"), scene="white")  # doctest: +SKIP
    >>> run.scan.cube.shape  # doctest: +SKIP
    """
    check_scan(rig, scene, light, pitch, roi)
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                "scan",
                f"bundle is for a {bundle.slm_shape} SLM, the rig has {rig.slm.shape}",
                "load this rig's bundle",
            )
        )
    session = Session.resume_or_plan(
        rig.description,
        lambda: _plan(rig, scene, light, pitch, 1, 0.6),
        session_id=session_id or _stamp(f"scan-{scene}"),
        data=data,
    )
    scan = capture_scan(rig, session, bundle, roi=roi, keep_raw=keep_raw, progress=progress)
    return ScanRun(scan, bundle.response is not None, session, bundle)
