"""Loading rig descriptions: YAML or a mapping -> schema -> dataclasses -> load-time checks.

The JSON Schema shipped beside the rig package (``rig.schema.json``) checks types, ranges
and unknown keys; :func:`~sassi_bench.rig.config.checks.check_description` then checks
physics and the named data sets. A ``backend: sim`` rig gets :data:`SIM_DEFAULTS` for the
keys it leaves out. Top-level sections the schema accepts but the description does not
hold are the virtual bench's own; they are set apart raw in ``bench_sections``.
"""

from __future__ import annotations

import json
import os
from dataclasses import fields
from importlib import resources
from pathlib import Path
from typing import Any

from sassi_bench._shared.yaml_io import load_yaml_mapping
from sassi_bench.errors import ConfigError, did_you_mean, step_error
from sassi_bench.optics.design import OpticalDesign, design_relay, nominal_summary
from sassi_bench.optics.design.zemax import design_mapping_from_file
from sassi_bench.rig.config.checks import check_description
from sassi_bench.rig.config.description import (
    BlurConfig,
    GuideCameraConfig,
    LightConfig,
    PrismConfig,
    RelayConfig,
    RigDescription,
    ScenesConfig,
    SellmeierConfig,
    SlmConfig,
    SpectralCameraConfig,
    SpectralGridConfig,
)
from sassi_bench.schema_validation import validate_against_schema

__all__ = ["SIM_DEFAULTS", "available_rigs", "load_rig_description", "rig_description_from_dict"]


#: Sections built into their own dataclass.
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


def _design_sections(data: dict[str, Any]) -> tuple[OpticalDesign, dict[str, Any]]:
    """A design rig's ``design`` and the ``relay``, ``prism`` and ``blur`` sections that
    follow from it (the described design traced once, then read from the cache)."""
    design = OpticalDesign.from_mapping(data["design"])
    grid = {**{"start_nm": 390.0, "stop_nm": 720.0}, **data.get("spectral_grid", {})}
    relay = design_relay(
        design,
        (data["slm"]["height"], data["slm"]["width"]),
        (data["spectral_camera"]["height"], data["spectral_camera"]["width"]),
        (float(grid["start_nm"]), float(grid["stop_nm"])),
    )
    summary = nominal_summary(design, relay)
    sections = {
        "relay": {
            "scale": summary.scale,
            "rotation_deg": 0.0,
            "offset_px": list(summary.offset_px),
            "distortion_k1": 0.0,
        },
        "prism": {
            "glass": summary.glass,
            "apex_deg": summary.apex_deg,
            "spread_px": summary.spread_px,
            "smile_px": summary.smile_px,
            "reference_nm": design.reference_nm,
        },
        "blur": {"sigma_px": {str(k): v for k, v in summary.sigma_px.items()}},
    }
    return design, sections


def _build(data: dict[str, Any], source: str | None) -> RigDescription:
    design = None
    if "design" in data:
        design, derived = _design_sections(data)
        data = {**{k: v for k, v in data.items() if k != "design"}, **derived}
    described = {f.name for f in fields(RigDescription)}
    kwargs: dict[str, Any] = {
        k: v for k, v in data.items() if k in described and k not in _SECTIONS
    }
    kwargs["bench_sections"] = {k: v for k, v in data.items() if k not in described}
    for key, cls in _SECTIONS.items():
        section = {k: v for k, v in data.get(key, {}).items() if v is not None}
        if data["backend"] == "sim":
            section = {**SIM_DEFAULTS.get(key, {}), **section}
        for name, value in list(section.items()):
            if isinstance(value, list):
                section[name] = tuple(tuple(v) if isinstance(v, list) else v for v in value)
        if key == "blur":
            section["sigma_px"] = {float(k): float(v) for k, v in section["sigma_px"].items()}
        if key == "prism" and "sellmeier" in section:
            own = section["sellmeier"]
            section["sellmeier"] = SellmeierConfig(
                tuple(float(x) for x in own["b"]), tuple(float(x) for x in own["c"])
            )
        kwargs[key] = cls(**section)
    kwargs["lasers_nm"] = tuple(float(x) for x in data["lasers_nm"])
    kwargs["wavelength_lamps"] = tuple(data.get("wavelength_lamps", ()))
    tolerance = data.get("laser_tolerance_nm")
    if isinstance(tolerance, dict):
        kwargs["laser_tolerance_nm"] = {float(k): float(v) for k, v in tolerance.items()}
    return RigDescription(source=source, design=design, **kwargs)


def rig_description_from_dict(
    data: dict[str, Any], source: str = "<dict>", folder: str | os.PathLike[str] | None = None
) -> RigDescription:
    """Validate a rig description given as a mapping (e.g. parsed YAML).

    A ``design: {file: ...}`` section is read here (a relative path against ``folder``,
    the rig YAML's; default the working folder) and held as the surfaces it means.

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
    design = data.get("design")
    if isinstance(design, dict) and "file" in design:
        data["design"] = design_mapping_from_file(design, Path(folder or Path.cwd()))
    _validate_schema(data, source)
    desc = _build(data, source if source != "<dict>" else None)
    check_description(desc)
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
        file, source = path, str(path)
    else:
        file = resources.files("sassi_bench.procedures").joinpath("rigs", f"{path}.yaml")
        if not file.is_file():
            raise ConfigError(
                step_error(
                    "rig description",
                    f"unknown rig {str(name_or_path)!r}{did_you_mean(path, available_rigs())}",
                    f"use one of {', '.join(available_rigs())} or a path to a YAML file",
                )
            )
        source = f"procedures/rigs/{path}.yaml"
    data = load_yaml_mapping(
        file,
        "rig description",
        label=source,
        missing_fix=f"check the path, or use one of the shipped rigs {', '.join(available_rigs())}",
        mapping_fix="write the rig as YAML keys (see procedures/rigs/sim.yaml)",
    )
    return rig_description_from_dict(data, source, folder=Path(str(file)).parent)
