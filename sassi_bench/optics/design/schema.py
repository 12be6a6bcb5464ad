"""A spectral arm described as an optical design: the rig YAML's ``design:`` section.

The arm runs from the SLM (the object plane) to the spectral camera (the image plane) as
sequential surfaces, the way an optical design program lists them. This module holds the
description and its checks only; nothing here needs the ray-tracing library
(:mod:`~sassi_bench.optics.design.build` turns it into one).

Geometry conventions (those of a design program):

* Each surface sits on the running axis; ``thickness_mm`` advances the axis to the next
  surface. A surface's own ``tilt_deg: [x, y, z]`` and ``decenter_mm: [x, y]`` move that
  surface alone (the axis after it is unchanged: a tilt and decenter restored after the
  surface).
* An entry ``coordinate_break: {decenter_mm: [x, y], tilt_deg: [x, y, z]}`` moves the
  running axis for every later surface: decenter first, then tilts about x, y, z in that
  order about the moved axes. ``coordinate_break: chief_ray`` is solved: the new axis
  starts where the on-axis chief ray (at ``reference_nm``) crosses the current plane and
  runs along it (the fold after a prism).
* Rotations are right-handed: a positive tilt about y turns +z towards +x. The
  dispersion must lie in the x-z plane (prisms tilted about y), so streaks run along the
  camera's rows, and shorter wavelengths must land at smaller camera x.
* ``image: {tilt_deg, decenter_mm}`` places the camera plane after the last surface's
  thickness; its z tilt is the sensor's roll (180: the relay's inverted image read
  upright).
* SLM pixel (u, v) sits at object (x, y) = ((u - (W-1)/2) p_slm, (v - (H-1)/2) p_slm);
  camera pixel (x, y) = ((W_c-1)/2 + x_img / p_cam, (H_c-1)/2 + y_img / p_cam).

Examples
--------
>>> design = OpticalDesign.from_mapping({
...     "slm_pixel_pitch_um": 8.0, "camera_pixel_pitch_um": 5.5,
...     "object_distance_mm": 25.0, "aperture": {"object_space_na": 0.02},
...     "surfaces": [{"radius_mm": 12.9, "thickness_mm": 3.0, "material": "N-BK7",
...                   "stop": True}, {"thickness_mm": 20.0}]})
>>> len(design.surfaces), design.surfaces[0].material
(2, 'N-BK7')
>>> with_override(design, {"surfaces": {2: {"thickness_mm": 20.5}}}).surfaces[1].thickness_mm
20.5
"""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from sassi_bench.errors import ConfigError, did_you_mean, step_error

__all__ = ["APERTURE_KINDS", "OpticalDesign", "Surface", "with_override"]

#: The ways the aperture may be given (exactly one).
APERTURE_KINDS = ("entrance_pupil_diameter_mm", "object_space_na", "working_f_number")

_SURFACE_KEYS = (
    "radius_mm",
    "conic",
    "thickness_mm",
    "material",
    "stop",
    "tilt_deg",
    "decenter_mm",
    "diameter_mm",
    "coordinate_break",
    "comment",
)
_DESIGN_KEYS = (
    "slm_pixel_pitch_um",
    "camera_pixel_pitch_um",
    "object_distance_mm",
    "aperture",
    "surfaces",
    "image",
    "reference_nm",
    "catalogue",
    "file_sha256",
)
_STEP = "rig description: design"


def _error(key: str, cause: str, fix: str) -> ConfigError:
    return ConfigError(step_error(_STEP, f"{key}: {cause}", fix))


@dataclass(frozen=True)
class Surface:
    """One entry of ``design.surfaces``: an optical surface or a coordinate break.

    Parameters
    ----------
    radius_mm
        Radius of curvature (None: flat).
    conic
        Conic constant.
    thickness_mm
        Distance along the running axis to the next entry.
    material
        Catalogue glass after the surface ("air" when left out).
    stop
        The aperture stop.
    tilt_deg, decenter_mm
        This surface's own tilt and decenter (restored after it).
    diameter_mm
        Clear aperture (None: unlimited), so vignetting is real.
    coordinate_break
        None, "chief_ray" or ``{decenter_mm, tilt_deg}``: moves the axis of every later
        entry.
    comment
        Free text (the part's name).
    """

    radius_mm: float | None = None
    conic: float = 0.0
    thickness_mm: float = 0.0
    material: str = "air"
    stop: bool = False
    tilt_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    decenter_mm: tuple[float, float] = (0.0, 0.0)
    diameter_mm: float | None = None
    coordinate_break: str | dict[str, Any] | None = None
    comment: str = ""

    @property
    def is_break(self) -> bool:
        """Whether this entry is a coordinate break (no optical surface)."""
        return self.coordinate_break is not None

    @property
    def is_tilted(self) -> bool:
        """Whether this surface is tilted (a prism face)."""
        return any(abs(a) > 0 for a in self.tilt_deg)


@dataclass(frozen=True)
class OpticalDesign:
    """The ``design:`` section: the spectral arm as sequential surfaces.

    Build it with :meth:`from_mapping`; :meth:`to_mapping` gives it back as the YAML's
    keys and :meth:`sha256` identifies it (the key of its traced grid).

    ``file_sha256`` is the SHA-256 of the design program's file the surfaces were read
    from (None for surfaces written in the YAML): it is part of the rig's description and
    hash, so an edited file makes another rig, but not of :meth:`sha256`, since the same
    surfaces trace the same.
    """

    slm_pixel_pitch_um: float
    camera_pixel_pitch_um: float
    object_distance_mm: float
    aperture: tuple[str, float]
    surfaces: tuple[Surface, ...]
    image_tilt_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    image_decenter_mm: tuple[float, float] = (0.0, 0.0)
    reference_nm: float = 550.0
    catalogue: str = "schott"
    file_sha256: str | None = None

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> OpticalDesign:
        """Check and build a design from the YAML's ``design:`` mapping.

        Raises
        ------
        ConfigError
            Naming the key (``design.surfaces[3].tilt_deg``), the cause and the fix.
        """
        if not isinstance(data, Mapping):
            raise _error("design", "expected a mapping of keys", "see docs/optical_design.md")
        if "file" in data:
            raise _error(
                "design.file",
                "a design program's file is read when the rig loads, not here",
                "load the rig with load_rig_description, or read the file with "
                "sassi_bench.optics.design.zemax.read_zemax_design",
            )
        _check_keys(data, _DESIGN_KEYS, "design")
        for key in ("slm_pixel_pitch_um", "camera_pixel_pitch_um", "object_distance_mm"):
            if key not in data:
                raise _error(f"design.{key}", "missing", "add it (see docs/optical_design.md)")
            if not float(data[key]) > 0:
                raise _error(f"design.{key}", f"{data[key]} is not > 0", "give a positive value")
        aperture = data.get("aperture")
        if not isinstance(aperture, Mapping) or len(aperture) != 1:
            raise _error(
                "design.aperture",
                "give exactly one aperture",
                f"write one of {', '.join(APERTURE_KINDS)}",
            )
        ((kind, value),) = aperture.items()
        if kind not in APERTURE_KINDS:
            raise _error(
                f"design.aperture.{kind}",
                f"unknown kind{did_you_mean(kind, APERTURE_KINDS)}",
                f"write one of {', '.join(APERTURE_KINDS)}",
            )
        if not float(value) > 0:
            raise _error(f"design.aperture.{kind}", f"{value} is not > 0", "give a positive value")
        raw = data.get("surfaces")
        if not isinstance(raw, list) or not raw:
            raise _error("design.surfaces", "no surfaces", "list the arm's surfaces in order")
        surfaces = tuple(_surface(entry, i) for i, entry in enumerate(raw, 1))
        stops = [i for i, s in enumerate(surfaces, 1) if s.stop]
        if len(stops) != 1:
            raise _error(
                "design.surfaces",
                f"{len(stops)} surfaces have stop: true",
                "mark exactly one surface (the iris) with stop: true",
            )
        medium = "air"
        for s in surfaces:
            if not s.is_break:
                medium = s.material
        if medium != "air":
            raise _error(
                "design.surfaces",
                "the last surface leaves the light in glass",
                "end the list with the last lens's exit surface (material left out: air)",
            )
        image = data.get("image", {}) or {}
        _check_keys(image, ("tilt_deg", "decenter_mm"), "design.image")
        file_sha256 = data.get("file_sha256")
        if file_sha256 is not None and not _is_sha256(file_sha256):
            raise _error(
                "design.file_sha256",
                f"{file_sha256!r} is not a SHA-256 hex digest",
                "leave the key out: it is set when the rig reads design.file",
            )
        return cls(
            slm_pixel_pitch_um=float(data["slm_pixel_pitch_um"]),
            camera_pixel_pitch_um=float(data["camera_pixel_pitch_um"]),
            object_distance_mm=float(data["object_distance_mm"]),
            aperture=(kind, float(value)),
            surfaces=surfaces,
            image_tilt_deg=_triple(image.get("tilt_deg"), "design.image.tilt_deg"),
            image_decenter_mm=_pair(image.get("decenter_mm"), "design.image.decenter_mm"),
            reference_nm=float(data.get("reference_nm", 550.0)),
            catalogue=str(data.get("catalogue", "schott")).lower(),
            file_sha256=file_sha256,
        )

    def to_mapping(self) -> dict[str, Any]:
        """The design as the YAML's keys (defaults left out).

        Examples
        --------
        >>> d = OpticalDesign.from_mapping({"slm_pixel_pitch_um": 8, "camera_pixel_pitch_um": 5.5,
        ...     "object_distance_mm": 25, "aperture": {"object_space_na": 0.02},
        ...     "surfaces": [{"thickness_mm": 10, "stop": True}]})
        >>> d.to_mapping()["surfaces"]
        [{'thickness_mm': 10.0, 'stop': True}]
        """
        default = Surface()
        surfaces = []
        for s in self.surfaces:
            entry: dict[str, Any] = {}
            for key in _SURFACE_KEYS:
                value = getattr(s, key)
                if value != getattr(default, key):
                    entry[key] = list(value) if isinstance(value, tuple) else value
            surfaces.append(entry)
        out: dict[str, Any] = {
            "slm_pixel_pitch_um": self.slm_pixel_pitch_um,
            "camera_pixel_pitch_um": self.camera_pixel_pitch_um,
            "object_distance_mm": self.object_distance_mm,
            "aperture": {self.aperture[0]: self.aperture[1]},
            "surfaces": surfaces,
            "reference_nm": self.reference_nm,
            "catalogue": self.catalogue,
        }
        image = {}
        if any(self.image_tilt_deg):
            image["tilt_deg"] = list(self.image_tilt_deg)
        if any(self.image_decenter_mm):
            image["decenter_mm"] = list(self.image_decenter_mm)
        if image:
            out["image"] = image
        if self.file_sha256 is not None:
            out["file_sha256"] = self.file_sha256
        return out

    def sha256(self) -> str:
        """SHA-256 of the design's canonical JSON (comments and the source file's hash left
        out: the same surfaces trace the same).

        Examples
        --------
        >>> d = OpticalDesign.from_mapping({"slm_pixel_pitch_um": 8, "camera_pixel_pitch_um": 5.5,
        ...     "object_distance_mm": 25, "aperture": {"object_space_na": 0.02},
        ...     "surfaces": [{"thickness_mm": 10, "stop": True, "comment": "iris"}]})
        >>> len(d.sha256())
        64
        """
        data = self.to_mapping()
        data.pop("file_sha256", None)
        for entry in data["surfaces"]:
            entry.pop("comment", None)
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def dispersing_glass(self) -> str:
        """The prism's glass: the material behind the first tilted surface.

        Raises
        ------
        ConfigError
            When no tilted surface leads into glass (a design without a prism).
        """
        for s in self.surfaces:
            if not s.is_break and s.is_tilted and s.material != "air":
                return s.material
        raise _error(
            "design.surfaces",
            "no prism: no tilted surface leads into glass",
            "give the prism's first face its tilt_deg and material",
        )


def with_override(
    design: OpticalDesign, override: Mapping[str, Any], where: str = "design override"
) -> OpticalDesign:
    """The design with some keys changed: ``{surfaces: {N: {key: value}}, image: {...},
    object_distance_mm: ...}``, surfaces counted from 1 as listed; ``where`` names the
    section the override came from in errors.

    Raises
    ------
    ConfigError
        On a surface number outside the list or an unknown key.
    """
    data = copy.deepcopy(design.to_mapping())
    _check_keys(override, ("surfaces", "image", "object_distance_mm"), where)
    for number, keys in (override.get("surfaces") or {}).items():
        index = int(number)
        if not 1 <= index <= len(data["surfaces"]):
            raise ConfigError(
                step_error(
                    f"rig description: {where}",
                    f"surfaces.{number}: there are surfaces 1..{len(data['surfaces'])}",
                    "count the design's surfaces from 1 as listed",
                )
            )
        _check_keys(keys, _SURFACE_KEYS, f"{where}.surfaces.{number}")
        data["surfaces"][index - 1].update(copy.deepcopy(dict(keys)))
    if "image" in override:
        data.setdefault("image", {}).update(dict(override["image"]))
    if "object_distance_mm" in override:
        data["object_distance_mm"] = override["object_distance_mm"]
    return OpticalDesign.from_mapping(data)


def _check_keys(data: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> None:
    if not isinstance(data, Mapping):
        raise _error(where, "expected a mapping of keys", "see docs/optical_design.md")
    for key in data:
        if key not in allowed:
            raise _error(
                f"{where}.{key}",
                f"unknown key{did_you_mean(key, allowed)}",
                f"use {', '.join(allowed)}",
            )


def _is_sha256(value: Any) -> bool:
    return (
        isinstance(value, str) and len(value) == 64 and all(c in "0123456789abcdef" for c in value)
    )


def _triple(value: Any, key: str) -> tuple[float, float, float]:
    if value is None:
        return (0.0, 0.0, 0.0)
    if not isinstance(value, list | tuple) or len(value) != 3:
        raise _error(key, f"{value!r} is not [x, y, z] degrees", "write three angles")
    return tuple(float(a) for a in value)  # type: ignore[return-value]


def _pair(value: Any, key: str) -> tuple[float, float]:
    if value is None:
        return (0.0, 0.0)
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise _error(key, f"{value!r} is not [x, y] mm", "write two lengths")
    return (float(value[0]), float(value[1]))


def _surface(entry: Any, index: int) -> Surface:
    where = f"design.surfaces[{index}]"
    _check_keys(entry, _SURFACE_KEYS, where)
    cb = entry.get("coordinate_break")
    if cb is not None:
        extra = set(entry) - {"coordinate_break", "thickness_mm", "comment"}
        if extra:
            raise _error(
                where,
                f"a coordinate break takes only thickness_mm beside it, not {sorted(extra)}",
                "put the optical surface in an entry of its own",
            )
        if cb != "chief_ray":
            _check_keys(cb, ("decenter_mm", "tilt_deg"), f"{where}.coordinate_break")
            cb = {
                "decenter_mm": list(_pair(cb.get("decenter_mm"), f"{where}.decenter_mm")),
                "tilt_deg": list(_triple(cb.get("tilt_deg"), f"{where}.tilt_deg")),
            }
    radius = entry.get("radius_mm")
    if radius is not None and float(radius) == 0:
        raise _error(f"{where}.radius_mm", "0 is no radius", "leave radius_mm out for a flat")
    diameter = entry.get("diameter_mm")
    if diameter is not None and not float(diameter) > 0:
        raise _error(f"{where}.diameter_mm", f"{diameter} is not > 0", "give the clear aperture")
    return Surface(
        radius_mm=None if radius is None else float(radius),
        conic=float(entry.get("conic", 0.0)),
        thickness_mm=float(entry.get("thickness_mm", 0.0)),
        material=str(entry.get("material", "air")),
        stop=bool(entry.get("stop", False)),
        tilt_deg=_triple(entry.get("tilt_deg"), f"{where}.tilt_deg"),
        decenter_mm=_pair(entry.get("decenter_mm"), f"{where}.decenter_mm"),
        diameter_mm=None if diameter is None else float(diameter),
        coordinate_break=cb,
        comment=str(entry.get("comment", "")),
    )
