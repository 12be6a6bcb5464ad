"""The rig YAML's bench-only sections, read by the virtual bench alone.

A rig description says what a bench is made of, as a lab knows it. A virtual bench can
also be told how it really differs from that description (section ``as_built``: lasers
off their label, another glass melt, the lamp's true temperature, ...) and which
real-bench nuisances to render (section ``nuisance``: laser power jitter, hot pixels, SLM
crosstalk, stray light, speckle). The description loader checks their shape against the
rig's JSON Schema and keeps them raw in ``RigDescription.bench_sections``, out of the
description's dictionary form and hash; they are parsed and checked here, inside
``rig/sim``, so no procedure, session, bundle or report can depend on them.

Examples
--------
>>> from sassi_bench.rig.config import rig_description_from_dict, load_rig_description
>>> data = load_rig_description("sim").to_dict()
>>> data["as_built"] = {"lasers_nm": {"635": 637.8}}
>>> desc = rig_description_from_dict(data)
>>> as_built_section(desc).lasers_nm, nuisance_section(desc).stray_light
({635.0: 637.8}, 0.0)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.optics.datasets import require_dataset
from sassi_bench.rig.config import RigDescription, rig_relative_path

__all__ = [
    "AsBuiltConfig",
    "DriftConfig",
    "NuisanceConfig",
    "as_built_section",
    "check_bench_sections",
    "nuisance_section",
]


@dataclass(frozen=True)
class AsBuiltConfig:
    """How the virtual bench as built differs from its description.

    Each key left out means "as described".
    """

    #: Nominal laser line (nm, as in ``lasers_nm``) -> the line's true centre (nm).
    lasers_nm: dict[float, float] = field(default_factory=dict)
    #: Added to the catalogue glass's refractive index at every wavelength.
    glass_index_offset: float = 0.0
    apex_deg: float | None = None
    halogen_k: float | None = None
    #: The LED's true spectrum: a colour-science illuminant name.
    led: str | None = None
    #: The guide camera's true curves: a colour-science camera name or a CSV path.
    guide_sensitivities: str | None = None
    slm_gamma: float | None = None
    #: Log-normal sigma of each lamp line's true intensity against its table.
    lamp_intensity_spread: float = 0.0
    #: The relay's true scale, rotation, offset and distortion (a collimator focal length,
    #: a mount, an alignment off the drawing); the prism and camera lens as described.
    relay_scale: float | None = None
    relay_rotation_deg: float | None = None
    relay_offset_px: tuple[float, float] | None = None
    relay_distortion_k1: float | None = None
    #: The SLM's true fill factor and contrast ratio.
    fill_factor: float | None = None
    contrast_ratio: float | None = None
    #: The optics' true PSF sigma over the described curve.
    blur_scale: float | None = None
    #: The spectral camera's true read noise, gain, full well and QE curve.
    read_noise_e: float | None = None
    gain_e_per_adu: float | None = None
    full_well_e: float | None = None
    qe: str | None = None
    #: The lasers' true line width (FWHM, nm).
    laser_fwhm_nm: float | None = None
    #: A design rig built off its design: ``{surfaces: {N: {key: value}}, image: {...},
    #: object_distance_mm: ...}`` (:func:`~sassi_bench.optics.design.with_override`).
    design: dict[str, Any] | None = None
    #: The prism rolled about the optical axis beyond its described alignment (degrees).
    prism_roll_deg: float = 0.0
    #: The camera at the best focus of another wavelength: the blur curve moved (nm).
    focus_shift_nm: float = 0.0


@dataclass(frozen=True)
class DriftConfig:
    """How the virtual bench's optics drift with time: a rate per hour and a random walk,
    on a bench clock that starts at ``start_h`` when the rig is opened and advances with
    every spectral frame's exposure plus ``frame_overhead_s``."""

    #: Bench clock (hours) when the rig is opened: 6.0 is "15:00" for a 09:00 calibration.
    start_h: float = 0.0
    #: Drift of the relay's image of the SLM centre on the camera (x, y), px per hour.
    relay_offset_px_per_h: tuple[float, float] = (0.0, 0.0)
    #: Drift of the relay's rotation, degrees per hour.
    relay_rotation_deg_per_h: float = 0.0
    #: Drift of the prism's tilt (its incidence angle), degrees per hour.
    prism_tilt_deg_per_h: float = 0.0
    #: Random walk of the relay offset (each axis), px per square-root hour.
    random_walk_px_per_sqrt_h: float = 0.0
    #: Bench time per spectral frame on top of its exposure, s.
    frame_overhead_s: float = 0.05


@dataclass(frozen=True)
class NuisanceConfig:
    """Real-bench nuisances the virtual bench renders; zero is none."""

    #: Relative RMS of the laser's power from frame to frame.
    laser_power_jitter: float = 0.0
    #: Fraction of the spectral camera's pixels that are hot.
    hot_pixels_fraction: float = 0.0
    #: Fraction of an open SLM pixel's light that leaks into each 4-neighbour.
    slm_crosstalk: float = 0.0
    #: Fraction of the scene's light spread evenly over the sensor.
    stray_light: float = 0.0
    #: Contrast of static multiplicative speckle under laser light.
    speckle_contrast: float = 0.0
    #: How the optics drift with time; None is a bench that holds still.
    drift: DriftConfig | None = None


def as_built_section(desc: RigDescription) -> AsBuiltConfig:
    """The rig's ``as_built`` section (every key as described where it is left out).

    Parameters
    ----------
    desc
        A loaded rig description.

    Returns
    -------
    AsBuiltConfig

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> as_built_section(load_rig_description("sim")) == AsBuiltConfig()
    True
    """
    section = dict(desc.bench_sections.get("as_built", {}))
    section["lasers_nm"] = {float(k): float(v) for k, v in section.get("lasers_nm", {}).items()}
    if section.get("relay_offset_px") is not None:
        section["relay_offset_px"] = tuple(float(x) for x in section["relay_offset_px"])
    return AsBuiltConfig(**section)


def nuisance_section(desc: RigDescription) -> NuisanceConfig:
    """The rig's ``nuisance`` section (every nuisance zero where it is left out).

    Parameters
    ----------
    desc
        A loaded rig description.

    Returns
    -------
    NuisanceConfig

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> nuisance_section(load_rig_description("sim")).laser_power_jitter
    0.0
    """
    section = dict(desc.bench_sections.get("nuisance", {}))
    if "drift" in section:
        drift = dict(section["drift"])
        if "relay_offset_px_per_h" in drift:
            drift["relay_offset_px_per_h"] = tuple(float(x) for x in drift["relay_offset_px_per_h"])
        section["drift"] = DriftConfig(**drift)
    return NuisanceConfig(**section)


def check_bench_sections(desc: RigDescription) -> None:
    """Check what the schema cannot: the lasers and data sets the sections name exist.

    Parameters
    ----------
    desc
        A loaded ``backend: sim`` rig description.

    Raises
    ------
    ConfigError
        Naming the description and the key.

    Examples
    --------
    >>> from sassi_bench.rig.config import rig_description_from_dict, load_rig_description
    >>> data = load_rig_description("sim").to_dict()
    >>> data["as_built"] = {"lasers_nm": {"640": 641.0}}
    >>> check_bench_sections(rig_description_from_dict(data))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: rig description sim: as_built.lasers_nm: 640 nm are not ...
    """
    as_built = as_built_section(desc)
    _check_design_sections(desc, as_built)
    unknown = sorted(set(as_built.lasers_nm) - set(desc.lasers_nm))
    if unknown:
        raise _error(
            desc,
            "as_built.lasers_nm",
            f"{', '.join(f'{x:g}' for x in unknown)} nm are not lines of lasers_nm "
            f"({', '.join(f'{x:g}' for x in desc.lasers_nm)})",
            "key each true centre by the nominal line it belongs to",
        )
    if as_built.led is not None:
        require_dataset("illuminant", as_built.led, "as_built.led")
    curves = as_built.guide_sensitivities
    if curves is None:
        return
    if not curves.lower().endswith(".csv"):
        require_dataset("camera", curves, "as_built.guide_sensitivities")
    elif not rig_relative_path(desc, curves).is_file():
        raise _error(
            desc,
            "as_built.guide_sensitivities",
            f"no such file {str(rig_relative_path(desc, curves))!r}",
            "give a CSV of wavelength_nm,r,g,b (relative to the rig YAML) or a "
            "colour-science camera name",
        )


def _check_design_sections(desc: RigDescription, as_built: AsBuiltConfig) -> None:
    """A design rig is built off its design through ``as_built.design`` only; a
    parametric rig has no design to build off."""
    if desc.design is None:
        if as_built.design is not None:
            raise _error(
                desc,
                "as_built.design",
                "the rig has no design: section",
                "describe the arm as a design, or use as_built.glass_index_offset / apex_deg",
            )
        return
    for key in ("glass_index_offset", "apex_deg"):
        if getattr(as_built, key) not in (None, 0.0):
            raise _error(
                desc,
                f"as_built.{key}",
                "a design rig's prism is one of its surfaces",
                "change the prism's surfaces under as_built.design.surfaces",
            )
    if as_built.design is not None:
        from sassi_bench.optics.design import with_override

        with_override(
            desc.design, as_built.design, "as_built.design"
        )  # numbers and keys checked here
    if nuisance_section(desc).drift is not None:
        raise _error(
            desc,
            "nuisance.drift",
            "drift is rendered on the parametric relay only",
            "leave nuisance.drift out of a design rig",
        )


def _error(desc: RigDescription, key: str, cause: str, fix: str) -> ConfigError:
    return ConfigError(
        step_error(f"rig description {desc.source or desc.name}", f"{key}: {cause}", fix)
    )
