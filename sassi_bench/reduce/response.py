"""The radiometric response: a white diffuser's scan under a source of known spectrum into
a per-bin response, published as a new bundle version.

:func:`response_source` is the source's spectrum (halogen as a blackbody of the rig's lamp
temperature, or a reference CSV), known before anything is captured;
:func:`publish_response` averages the white's column sums, deblurs their mean once, divides
by the source's photons per bin and publishes the response
(:func:`~sassi_bench.workflows.scan.run_response` scans the diffuser).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle, QualityCheck, publish_derived
from sassi_bench.calibrate.radiometry import (
    read_reference_csv,
    response_from_white,
    source_photons_in_bins,
    temperature_sensitivity,
)
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.response_budget import ResponseFrameRecord
from sassi_bench.rig.config import RigDescription
from sassi_bench.spectra.deblur import MeanSpectrum
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.scan import ScanCube
from sassi_bench.spectra.scan_deblur import scan_mean_spectrum

__all__ = [
    "LAMP_DELTA_K",
    "ResponseSource",
    "publish_response",
    "response_source",
    "white_mean",
]


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
    desc: RigDescription,
    temperature_k: float | None = None,
    reference_csv: str | os.PathLike[str] | None = None,
) -> ResponseSource:
    """The source of a response scan: a reference CSV, else a blackbody at ``temperature_k``
    or the rig's ``light.halogen_k``; refused before any capture when none is known.

    Parameters
    ----------
    desc
        The rig's description (its ``light.halogen_k``).
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
    >>> from sassi_bench.rig.config import load_rig_description
    >>> response_source(load_rig_description("sim"), temperature_k=3100).label
    'blackbody 3100 K'
    """
    if reference_csv is not None:
        return ResponseSource(None, read_reference_csv(reference_csv), str(reference_csv))
    kelvin = temperature_k if temperature_k is not None else desc.light.halogen_k
    if kelvin is None:
        raise ProcedureError(
            step_error(
                "radiometric response",
                f"rig {desc.name!r} does not give its halogen lamp's colour "
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


def _lit(scan: ScanCube) -> np.ndarray:
    return (scan.quality == 0) & (np.abs(scan.cube).sum(axis=-1) > 0)


def white_mean(scan: ScanCube, bundle: CalibrationBundle) -> MeanSpectrum:
    """The white diffuser's deblurred mean spectrum over its lit pixels, with its 1-sigma.

    The white's column sums are averaged first and deblurred once, at the mean's noise:
    noise averages out of a mean, the per-pixel deblur's smoothing bias would not.

    Examples
    --------
    Not run here (it needs captured sessions)::

        white = white_mean(scan, bundle)
    """
    return scan_mean_spectrum(scan, StreakForwardModel.from_bundle(bundle), _lit(scan))


def publish_response(
    scan: ScanCube,
    session: Session,
    bundle: CalibrationBundle,
    desc: RigDescription,
    source: ResponseSource,
    *,
    light: str,
    pitch: tuple[int, int],
    every: int,
    reflectance: float = 1.0,
    data: str | os.PathLike[str] | None = None,
    allow_failed: bool = False,
    frames: ResponseFrameRecord | None = None,
) -> Path:
    """The per-bin response from a white diffuser's scan, published in a new bundle.

    The white's column sums are averaged first and deblurred once, at the mean's noise:
    noise averages out of a mean, the per-pixel deblur's smoothing bias would not.

    Parameters
    ----------
    scan
        The white diffuser's scan, assembled with ``keep_raw=True``.
    session
        Its session.
    bundle
        The bundle it was assembled with; the new version derives from it.
    desc
        The rig's description.
    source
        The spectrum the diffuser was lit with (:func:`response_source`).
    light, pitch, every, reflectance
        The scan's light, pinhole pitch and thinning, and the diffuser's reflectance
        (recorded in the bundle's procedure).
    data
        Data root for bundles.
    allow_failed
        Publish although a check failed.
    frames
        What the scan took and why (:mod:`~sassi_bench.reduce.response_budget`): recorded,
        and the colour 1-sigma its noise causes checked against its tolerance
        (``response.de00_sigma``); the worst bin's relative 1-sigma too
        (``response.sigma_relative``) when the procedure set one.

    Returns
    -------
    pathlib.Path
        The new bundle's folder.

    Examples
    --------
    Not run here (it needs captured sessions)::

        path = publish_response(scan, session, bundle, desc, source, light="halogen",
                                pitch=(100, 5), every=25)
    """
    spectra = scan.cube[_lit(scan)]
    white = white_mean(scan, bundle)
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
    if frames is not None:
        residuals["response_frames"] = frames.to_json()
        residuals["notes"] = [frames.note()]
        tolerances = frames.settings
        checks.append(
            QualityCheck.at_most("de00_sigma", frames.de00_sigma, tolerances.de00_max, "dE00")
        )
        if tolerances.sigma_max is not None:
            checks.append(
                QualityCheck.at_most("sigma_relative", frames.sigma, tolerances.sigma_max, "1")
            )
    return publish_derived(
        bundle,
        stage="response",
        rig=desc,
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
