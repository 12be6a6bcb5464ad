"""Rig descriptions: YAML files that say what a bench is made of.

A rig YAML is validated against the JSON Schema shipped beside this module (types,
ranges, no unknown keys), then against physics (the SLM's image and its spectral
streaks must fit on the spectral camera, the lasers must lie on the spectral grid) and
the data sets it names (glass, lamps, guide sensor, QE curve), all when it is loaded.
Errors name the key as a dotted path, with the closest valid name for a typo.

Two sections describe the virtual bench only, never the procedures' view of it:
``as_built`` (how the bench as built differs from this description: lasers off their
label, another glass melt, the lamp's true temperature, ...) and ``nuisance`` (laser
power jitter, hot pixels, SLM crosstalk, stray light, speckle). They are parsed into
:class:`AsBuiltConfig` and :class:`NuisanceConfig` on the description for the virtual
bench, and left out of :meth:`RigDescription.to_dict` and the rig's hash, so no session,
bundle or report carries them; a guard test checks that nothing outside ``rig/sim``
reads them.

Keys whose values are the virtual bench's own parts (its guide sensor, its halogen
lamp's temperature, ...) default to those values only on a ``backend: sim`` rig
(:data:`SIM_DEFAULTS`); a real rig that leaves them out gets None, and the workbench
uses the documented fallback.

Examples
--------
>>> desc = load_rig_description("sim")
>>> desc.slm.width, desc.prism.glass
(640, 'N-BK7')
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sassi_bench.errors import ConfigError, did_you_mean, step_error
from sassi_bench.optics.blur import PsfSigmaCurve, line_spread_sigma
from sassi_bench.optics.datasets import photo_loader, require_dataset
from sassi_bench.optics.glass import get_glass
from sassi_bench.optics.relay import BAND_NM, SpectralRelay
from sassi_bench.optics.sensor import qe_curve
from sassi_bench.schema_validation import validate_against_schema

__all__ = [
    "SIM_DEFAULTS",
    "AsBuiltConfig",
    "BlurConfig",
    "GuideCameraConfig",
    "LightConfig",
    "NuisanceConfig",
    "PrismConfig",
    "RelayConfig",
    "RigDescription",
    "ScenesConfig",
    "SlmConfig",
    "SpectralCameraConfig",
    "SpectralGridConfig",
    "available_rigs",
    "light_names",
    "load_rig_description",
    "rig_description_from_dict",
]


def light_names(lasers_nm: tuple[float, ...]) -> tuple[str, ...]:
    """The light names of a rig with these laser lines.

    Examples
    --------
    >>> light_names((450.0, 532.5))
    ('off', 'laser:450', 'laser:532.5', 'led', 'halogen', 'fluorescent')
    """
    return ("off", *(f"laser:{x:g}" for x in lasers_nm), "led", "halogen", "fluorescent")


@dataclass(frozen=True)
class SlmConfig:
    width: int
    height: int
    contrast_ratio: float
    gamma: float = 2.2
    fill_factor: float = 0.93


@dataclass(frozen=True)
class SpectralCameraConfig:
    width: int
    height: int
    read_noise_e: float
    full_well_e: float
    bit_depth: int
    dark_offset_adu: float = 100.0
    dark_current_e_per_s: float = 0.5
    qe: str | dict[str, float] | None = None
    exposure_range_s: tuple[float, float] = (1e-5, 10.0)


@dataclass(frozen=True)
class RelayConfig:
    scale: float
    rotation_deg: float
    offset_px: tuple[float, float]
    distortion_k1: float


@dataclass(frozen=True)
class PrismConfig:
    glass: str
    apex_deg: float
    spread_px: float
    smile_px: float
    incidence_deg: float | None = None
    reference_nm: float = 550.0


@dataclass(frozen=True)
class BlurConfig:
    sigma_px: dict[float, float]


@dataclass(frozen=True)
class GuideCameraConfig:
    width: int
    height: int
    scale: float = 1.0
    rotation_deg: float = 0.0
    offset_px: tuple[float, float] = (0.0, 0.0)
    homography: tuple[tuple[float, ...], ...] | None = None
    read_noise_e: float = 3.0
    full_well_e: float = 10000.0
    bit_depth: int = 12
    sensitivities: str | None = None
    blur_px: float = 0.6
    exposure_range_s: tuple[float, float] = (1e-5, 10.0)


@dataclass(frozen=True)
class LightConfig:
    laser_fwhm_nm: float = 1.0
    laser_flux: float = 2.0e6
    broadband_flux: float = 2.0e7
    led: str | None = None
    halogen_k: float | None = None
    fluorescent: str | None = None


@dataclass(frozen=True)
class SpectralGridConfig:
    start_nm: float = 390.0
    stop_nm: float = 720.0
    step_nm: float = 2.0


@dataclass(frozen=True)
class ScenesConfig:
    margin_px: int = 48
    colorchecker_data: str = "BabelColor Average"
    colorchecker_rotation_deg: float = 1.5
    natural_image: str = "coffee"


@dataclass(frozen=True)
class AsBuiltConfig:
    """How the virtual bench as built differs from its description (bench-only).

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


@dataclass(frozen=True)
class NuisanceConfig:
    """Real-bench nuisances the virtual bench renders (bench-only); zero is none."""

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


@dataclass(frozen=True)
class RigDescription:
    """A validated rig description (all defaults filled in).

    Use :func:`load_rig_description` to build one from YAML and :meth:`to_dict` for
    the canonical JSON-compatible form stored in calibration bundles.
    """

    name: str
    backend: str
    slm: SlmConfig
    spectral_camera: SpectralCameraConfig
    relay: RelayConfig
    prism: PrismConfig
    blur: BlurConfig
    guide_camera: GuideCameraConfig
    lasers_nm: tuple[float, ...]
    seed: int = 0
    description: str = ""
    light: LightConfig = field(default_factory=LightConfig)
    spectral_grid: SpectralGridConfig = field(default_factory=SpectralGridConfig)
    scenes: ScenesConfig = field(default_factory=ScenesConfig)
    hardware: dict[str, Any] | None = None
    source: str | None = None
    # Bench-only sections: not part of the description procedures rely on, its
    # dictionary form or its hash (see the module docstring).
    as_built: AsBuiltConfig = field(default_factory=AsBuiltConfig, repr=False, compare=False)
    nuisance: NuisanceConfig = field(default_factory=NuisanceConfig, repr=False, compare=False)

    @property
    def light_names(self) -> tuple[str, ...]:
        """The names of the rig's lights: ``off``, ``laser:<nm>`` per line, ``led``,
        ``halogen`` and ``fluorescent``.

        Examples
        --------
        >>> load_rig_description("sim").light_names[:3]
        ('off', 'laser:450', 'laser:520')
        """
        return light_names(self.lasers_nm)

    def to_dict(self) -> dict[str, Any]:
        """Canonical JSON-compatible form (the ``source`` path and the bench-only
        ``as_built`` and ``nuisance`` sections are left out)."""
        data = asdict(self)
        for key in ("source", "as_built", "nuisance"):
            data.pop(key)
        if data["hardware"] is None:
            data.pop("hardware")
        return json.loads(json.dumps(data, sort_keys=True))

    def sha256(self) -> str:
        """SHA-256 of the canonical JSON form; identifies the rig in bundles.

        Where hardware is plugged in (serial port, monitor, producer or library path,
        timeouts) is left out: moving a cable does not make another rig.
        """
        data = self.to_dict()
        if "hardware" in data:
            data["hardware"] = _without_connection(data["hardware"])
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def nominal_relay(self) -> SpectralRelay:
        """The SLM -> spectral camera optics as described: a ray trace of the relay and prism.

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> relay = load_rig_description("sim").nominal_relay()
        >>> x, _ = relay.forward(319.5, 199.5, [400.0, 700.0])
        >>> round(float(x[1] - x[0]), 6)  # prism.spread_px
        68.0
        """
        relay, prism = self.relay, self.prism
        return SpectralRelay(
            (self.slm.height, self.slm.width),
            (self.spectral_camera.height, self.spectral_camera.width),
            scale=relay.scale,
            rotation_deg=relay.rotation_deg,
            offset_px=relay.offset_px,
            distortion_k1=relay.distortion_k1,
            glass=get_glass(prism.glass),
            apex_deg=prism.apex_deg,
            spread_px=prism.spread_px,
            smile_px=prism.smile_px,
            incidence_deg=prism.incidence_deg,
            reference_nm=prism.reference_nm,
        )


_CONNECTION_KEYS = {"port", "baudrate", "timeout_s", "boot_s", "monitor", "cti", "library"}


def _without_connection(hardware: dict[str, Any]) -> dict[str, Any]:
    return {
        device: {k: v for k, v in spec.items() if k not in _CONNECTION_KEYS}
        for device, spec in hardware.items()
    }


#: Sections built into their own dataclass; ``as_built`` and ``nuisance`` are built apart.
_SECTIONS: dict[str, type] = {
    "slm": SlmConfig,
    "spectral_camera": SpectralCameraConfig,
    "relay": RelayConfig,
    "prism": PrismConfig,
    "blur": BlurConfig,
    "guide_camera": GuideCameraConfig,
    "light": LightConfig,
    "spectral_grid": SpectralGridConfig,
    "scenes": ScenesConfig,
}


def _schema() -> dict[str, Any]:
    text = resources.files("sassi_bench.rig").joinpath("rig.schema.json").read_text()
    return json.loads(text)


def _validate_schema(data: dict[str, Any], source: str) -> None:
    validate_against_schema(data, _schema(), f"rig description {source}")


#: Values a ``backend: sim`` rig gets for keys it leaves out (or sets to null): the parts
#: of the virtual bench itself. A real rig never gets them: these keys stay None there
#: (the guide rendering then uses CIE 1931 -> sRGB, the radiometric response needs the
#: lamp's temperature or a reference spectrum, the rest describe simulated parts).
SIM_DEFAULTS: dict[str, dict[str, Any]] = {
    "spectral_camera": {"qe": "scmos"},
    "guide_camera": {"sensitivities": "Nikon 5100 (NPL)"},
    "light": {"led": "LED-B3", "halogen_k": 3000.0, "fluorescent": "FL2"},
}


def _build(data: dict[str, Any], source: str | None) -> RigDescription:
    bench_only = ("as_built", "nuisance")
    kwargs: dict[str, Any] = {
        k: v for k, v in data.items() if k not in _SECTIONS and k not in bench_only
    }
    for key, cls in _SECTIONS.items():
        section = {k: v for k, v in data.get(key, {}).items() if v is not None}
        if data["backend"] == "sim":
            section = {**SIM_DEFAULTS.get(key, {}), **section}
        for name, value in list(section.items()):
            if isinstance(value, list):
                section[name] = tuple(tuple(v) if isinstance(v, list) else v for v in value)
        if key == "blur":
            section["sigma_px"] = {float(k): float(v) for k, v in section["sigma_px"].items()}
        kwargs[key] = cls(**section)
    kwargs["lasers_nm"] = tuple(float(x) for x in data["lasers_nm"])
    as_built = dict(data.get("as_built", {}))
    as_built["lasers_nm"] = {float(k): float(v) for k, v in as_built.get("lasers_nm", {}).items()}
    kwargs["as_built"] = AsBuiltConfig(**as_built)
    kwargs["nuisance"] = NuisanceConfig(**data.get("nuisance", {}))
    return RigDescription(source=source, **kwargs)


def _error(desc: RigDescription, key: str, cause: str, fix: str) -> ConfigError:
    """A :class:`ConfigError` naming the description and the key."""
    return ConfigError(
        step_error(f"rig description {desc.source or desc.name}", f"{key}: {cause}", fix)
    )


def _check_backend(desc: RigDescription) -> None:
    if desc.backend == "hardware" and desc.hardware is None:
        raise _error(
            desc,
            "hardware",
            "backend 'hardware' needs a hardware section",
            "add one (see procedures/rigs/lab-example.yaml)",
        )
    if desc.backend != "hardware" and desc.hardware is not None:
        raise _error(
            desc,
            "hardware",
            f"only read with backend 'hardware' (this rig's backend is {desc.backend!r})",
            "remove the section or change the backend",
        )


def _check_bench_only(desc: RigDescription) -> None:
    """``as_built`` and ``nuisance`` describe a virtual bench, and name lasers it has."""
    if desc.backend == "sim":
        unknown = sorted(set(desc.as_built.lasers_nm) - set(desc.lasers_nm))
        if unknown:
            raise _error(
                desc,
                "as_built.lasers_nm",
                f"{', '.join(f'{x:g}' for x in unknown)} nm are not lines of lasers_nm "
                f"({', '.join(f'{x:g}' for x in desc.lasers_nm)})",
                "key each true centre by the nominal line it belongs to",
            )
        return
    for key, section, default in (
        ("as_built", desc.as_built, AsBuiltConfig()),
        ("nuisance", desc.nuisance, NuisanceConfig()),
    ):
        if section != default:
            raise _error(
                desc,
                key,
                f"only read by the virtual bench (this rig's backend is {desc.backend!r})",
                "remove the section: a real bench is as built already",
            )


def _check_ranges(desc: RigDescription) -> None:
    grid = desc.spectral_grid
    if grid.stop_nm - grid.start_nm < 10:
        raise _error(
            desc, "spectral_grid", "stop_nm must exceed start_nm by at least 10 nm", "widen it"
        )
    if grid.start_nm > 400 or grid.stop_nm < 700:
        raise _error(
            desc,
            "spectral_grid",
            f"{grid.start_nm:g}-{grid.stop_nm:g} nm does not cover the calibrated band, 400-700 nm",
            "set start_nm <= 400 and stop_nm >= 700",
        )
    outside = [x for x in desc.lasers_nm if not grid.start_nm <= x <= grid.stop_nm]
    if outside:
        raise _error(
            desc,
            "lasers_nm",
            f"{', '.join(f'{x:g}' for x in outside)} nm lie outside the spectral grid "
            f"{grid.start_nm:g}-{grid.stop_nm:g} nm",
            "remove them or widen spectral_grid",
        )
    for key, rng in (
        ("spectral_camera.exposure_range_s", desc.spectral_camera.exposure_range_s),
        ("guide_camera.exposure_range_s", desc.guide_camera.exposure_range_s),
    ):
        if not 0 < rng[0] < rng[1]:
            raise _error(desc, key, f"got {list(rng)}", "give [min, max] with 0 < min < max")
    if desc.guide_camera.homography is not None:
        h = np.asarray(desc.guide_camera.homography, dtype=float)
        if abs(np.linalg.det(h)) < 1e-12:
            raise _error(
                desc, "guide_camera.homography", "the matrix is singular", "give an invertible 3x3"
            )
    cam = desc.spectral_camera
    if cam.dark_offset_adu >= 2**cam.bit_depth - 1:
        raise _error(
            desc,
            "spectral_camera.dark_offset_adu",
            f"{cam.dark_offset_adu:g} ADU is not below the {cam.bit_depth}-bit ADC range",
            "give the camera's black level in ADU",
        )


def _check_named_data(desc: RigDescription) -> None:
    """Every glass, lamp, sensor and curve the description names must exist."""
    get_glass(desc.prism.glass)
    if desc.spectral_camera.qe is not None:
        qe_curve(desc.spectral_camera.qe, key="spectral_camera.qe")
    if desc.guide_camera.sensitivities is not None:
        require_dataset("camera", desc.guide_camera.sensitivities, "guide_camera.sensitivities")
    for key in ("led", "fluorescent"):
        name = getattr(desc.light, key)
        if name is not None:
            require_dataset("illuminant", name, f"light.{key}")
    if desc.as_built.led is not None:
        require_dataset("illuminant", desc.as_built.led, "as_built.led")
    curves = desc.as_built.guide_sensitivities
    if curves is not None:
        if curves.lower().endswith(".csv"):
            path = as_built_path(desc, curves)
            if not path.is_file():
                raise _error(
                    desc,
                    "as_built.guide_sensitivities",
                    f"no such file {str(path)!r}",
                    "give a CSV of wavelength_nm,r,g,b (relative to the rig YAML) or a "
                    "colour-science camera name",
                )
        else:
            require_dataset("camera", curves, "as_built.guide_sensitivities")
    if desc.backend == "sim":  # the scenes are the virtual bench's
        require_dataset("colourchecker", desc.scenes.colorchecker_data, "scenes.colorchecker_data")
        photo_loader(desc.scenes.natural_image)


def _check_streaks_fit(desc: RigDescription) -> None:
    """The SLM's image with its 400-700 nm streaks (and 3 sigma of blur) must lie on the
    spectral camera, by the description's nominal optics (a ray trace through the prism)."""
    band = np.array(BAND_NM)
    blur = PsfSigmaCurve(desc.blur.sigma_px)(band)
    h, w = desc.slm.height, desc.slm.width
    hc, wc = desc.spectral_camera.height, desc.spectral_camera.width
    relay = desc.nominal_relay()
    u = np.array([0.0, w - 1, 0.0, w - 1])[:, None]
    v = np.array([0.0, 0.0, h - 1, h - 1])[:, None]
    x, y = relay.forward(u, v, band[None, :])
    reach = 3.0 * float(line_spread_sigma(blur, desc.relay.scale, desc.slm.fill_factor).max())
    x0, x1, y0, y1 = x.min() - reach, x.max() + reach, y.min() - reach, y.max() + reach
    if not np.all(np.isfinite(x)) or x0 < 0 or x1 > wc - 1 or y0 < 0 or y1 > hc - 1:
        raise _error(
            desc,
            "relay",
            f"the SLM's image with its 400-700 nm streaks spans camera x {x0:.0f}..{x1:.0f}, "
            f"y {y0:.0f}..{y1:.0f}, outside the {wc}x{hc} camera",
            "lower relay.scale or prism.spread_px, or move relay.offset_px",
        )


def as_built_path(desc: RigDescription, name: str) -> Path:
    """A file an ``as_built`` key names, relative to the rig YAML's folder."""
    path = Path(name)
    if not path.is_absolute() and desc.source is not None and Path(desc.source).is_file():
        path = Path(desc.source).parent / path
    return path


#: The checks a description passes after its schema, in order. Each takes the built
#: description and raises :class:`ConfigError` naming the key.
_CHECKS = (_check_backend, _check_bench_only, _check_ranges, _check_named_data, _check_streaks_fit)


def rig_description_from_dict(data: dict[str, Any], source: str = "<dict>") -> RigDescription:
    """Validate a rig description given as a mapping (e.g. parsed YAML).

    Raises
    ------
    ConfigError
        Naming the offending key, on unknown keys, wrong types or impossible values.

    Examples
    --------
    >>> base = load_rig_description("sim").to_dict()
    >>> base["prism"]["apex_deg"] = 120
    >>> try:  # doctest: +ELLIPSIS
    ...     rig_description_from_dict(base)
    ... except ConfigError as exc:
    ...     print(exc)
    rig description <dict>: prism.apex_deg: 120 is greater than the maximum of 75. Fix: correct ...
    """
    if not isinstance(data, dict):
        raise ConfigError(
            step_error(
                f"rig description {source}",
                f"expected a mapping of keys at the top level, got {type(data).__name__}",
                "write the rig as YAML keys (see procedures/rigs/sim.yaml)",
            )
        )
    data = json.loads(json.dumps(data))  # YAML int keys -> str, tuples -> lists
    _validate_schema(data, source)
    desc = _build(data, source if source != "<dict>" else None)
    for check in _CHECKS:
        check(desc)
    return desc


def available_rigs() -> list[str]:
    """Names of the rig descriptions shipped in ``procedures/rigs``."""
    folder = resources.files("sassi_bench.procedures").joinpath("rigs")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def load_rig_description(name_or_path: str | os.PathLike[str]) -> RigDescription:
    """Load and validate a rig description by shipped name or by path.

    Parameters
    ----------
    name_or_path
        ``"sim"``, ``"sim-prototype"`` (files in ``procedures/rigs``) or a path to a
        YAML file describing another rig.

    Returns
    -------
    RigDescription

    Examples
    --------
    >>> load_rig_description("sim-prototype").slm.width
    1920
    """
    path = Path(name_or_path)
    # A folder named like a rig (the data root keeps bundles in ``<rig>/``) is not a path.
    if path.suffix in (".yaml", ".yml") or path.is_file():
        if not path.is_file():
            raise ConfigError(
                step_error(
                    "rig description",
                    f"no such file {str(path)!r}",
                    f"check the path, or use one of the shipped rigs {', '.join(available_rigs())}",
                )
            )
        text = path.read_text()
        source = str(path)
    else:
        resource = resources.files("sassi_bench.procedures").joinpath("rigs", f"{path}.yaml")
        if not resource.is_file():
            raise ConfigError(
                step_error(
                    "rig description",
                    f"unknown rig {str(name_or_path)!r}{did_you_mean(path, available_rigs())}",
                    f"use one of {', '.join(available_rigs())} or a path to a YAML file",
                )
            )
        text = resource.read_text()
        source = f"procedures/rigs/{path}.yaml"
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(
            step_error(
                f"rig description {source}",
                f"not valid YAML ({' '.join(str(exc).split())})",
                "correct the YAML syntax at the line named",
            )
        ) from exc
    return rig_description_from_dict(data, source)
