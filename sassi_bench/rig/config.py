"""Rig descriptions: YAML files that say what a bench is made of.

A rig YAML is validated against the JSON Schema shipped beside this module (types,
ranges, no unknown keys) and then against physics (the SLM's image and its spectral
streaks must fit on the spectral camera). Errors name the key as a dotted path.

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

from sassi_bench.errors import ConfigError
from sassi_bench.schema_validation import validate_against_schema

__all__ = [
    "BlurConfig",
    "GuideCameraConfig",
    "LightConfig",
    "PrismConfig",
    "RelayConfig",
    "RigDescription",
    "ScenesConfig",
    "SlmConfig",
    "SpectralCameraConfig",
    "SpectralGridConfig",
    "available_rigs",
    "load_rig_description",
    "rig_description_from_dict",
]


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
    qe: str | dict[str, float] = "scmos"
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
    sensitivities: str = "Nikon 5100 (NPL)"
    blur_px: float = 0.6
    exposure_range_s: tuple[float, float] = (1e-5, 10.0)


@dataclass(frozen=True)
class LightConfig:
    laser_fwhm_nm: float = 1.0
    laser_flux: float = 2.0e6
    broadband_flux: float = 2.0e7
    led: str = "LED-B3"
    halogen_k: float = 3000.0
    fluorescent: str = "FL2"


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

    def to_dict(self) -> dict[str, Any]:
        """Canonical JSON-compatible form (the ``source`` path is left out)."""
        data = asdict(self)
        data.pop("source")
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


_CONNECTION_KEYS = {"port", "baudrate", "timeout_s", "boot_s", "monitor", "cti", "library"}


def _without_connection(hardware: dict[str, Any]) -> dict[str, Any]:
    return {
        device: {k: v for k, v in spec.items() if k not in _CONNECTION_KEYS}
        for device, spec in hardware.items()
    }


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


def _build(data: dict[str, Any], source: str | None) -> RigDescription:
    kwargs: dict[str, Any] = {k: v for k, v in data.items() if k not in _SECTIONS}
    for key, cls in _SECTIONS.items():
        section = dict(data.get(key, {}))
        for name, value in list(section.items()):
            if isinstance(value, list):
                section[name] = tuple(tuple(v) if isinstance(v, list) else v for v in value)
        if key == "blur":
            section["sigma_px"] = {float(k): float(v) for k, v in section["sigma_px"].items()}
        kwargs[key] = cls(**section)
    kwargs["lasers_nm"] = tuple(float(x) for x in data["lasers_nm"])
    return RigDescription(source=source, **kwargs)


def _check_backend(desc: RigDescription) -> None:
    if desc.backend == "hardware" and desc.hardware is None:
        raise ConfigError(
            "hardware: backend 'hardware' needs a hardware section "
            "(see procedures/rigs/lab-example.yaml)"
        )
    if desc.backend != "hardware" and desc.hardware is not None:
        raise ConfigError(
            f"hardware: only read with backend 'hardware' (this rig's backend is "
            f"{desc.backend!r}); remove the section or change the backend"
        )


def _check_physics(desc: RigDescription) -> None:
    if desc.spectral_grid.stop_nm - desc.spectral_grid.start_nm < 10:
        raise ConfigError("spectral_grid: stop_nm must exceed start_nm by at least 10 nm")
    if desc.spectral_grid.start_nm > 400 or desc.spectral_grid.stop_nm < 700:
        raise ConfigError("spectral_grid: must cover 400-700 nm (the calibrated band)")
    for key, rng in (
        ("spectral_camera.exposure_range_s", desc.spectral_camera.exposure_range_s),
        ("guide_camera.exposure_range_s", desc.guide_camera.exposure_range_s),
    ):
        if not 0 < rng[0] < rng[1]:
            raise ConfigError(f"{key}: need 0 < min < max, got {list(rng)}")
    if desc.guide_camera.homography is not None:
        h = np.asarray(desc.guide_camera.homography, dtype=float)
        if abs(np.linalg.det(h)) < 1e-12:
            raise ConfigError("guide_camera.homography: matrix is singular")
    if desc.spectral_camera.dark_offset_adu >= 2**desc.spectral_camera.bit_depth - 1:
        raise ConfigError("spectral_camera.dark_offset_adu: must be below the ADC range")
    from sassi_bench.optics.glass import get_glass

    get_glass(desc.prism.glass)


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
    >>> rig_description_from_dict(base)
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: rig description <dict> is invalid:
      prism.apex_deg: 120 is greater than the maximum of 75
    """
    if not isinstance(data, dict):
        raise ConfigError(f"rig description {source}: expected a mapping at the top level")
    data = json.loads(json.dumps(data))  # YAML int keys -> str, tuples -> lists
    _validate_schema(data, source)
    desc = _build(data, source if source != "<dict>" else None)
    _check_backend(desc)
    _check_physics(desc)
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
            raise ConfigError(f"rig description: no such file {str(path)!r}")
        text = path.read_text()
        source = str(path)
    else:
        resource = resources.files("sassi_bench.procedures").joinpath("rigs", f"{path}.yaml")
        if not resource.is_file():
            raise ConfigError(
                f"rig description: unknown rig {str(name_or_path)!r}. "
                f"Fix: use one of {available_rigs()} or a path to a YAML file"
            )
        text = resource.read_text()
        source = f"procedures/rigs/{path}.yaml"
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"rig description {source}: not valid YAML ({exc})") from exc
    return rig_description_from_dict(data, source)
