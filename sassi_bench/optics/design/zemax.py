"""A spectral arm read from a Zemax OpticStudio sequential file (``design: {file: arm.zmx}``).

The file is read by optiland's own Zemax parser (:mod:`optiland.fileio.zemax`) into its
data model; this module turns that model into the same
:class:`~sassi_bench.optics.design.schema.OpticalDesign` a ``design.surfaces`` list gives,
so the file's arm is placed, traced and cached exactly like a written one. What the
design cannot reproduce is refused, never traced approximately.

Why not optiland's own converter (the model to an ``Optic``): it ignores a coordinate
break's order flag and composes a break's tilts in another order than OpticStudio, which
is exact for single-axis breaks only; and its glass lookup searches every catalogue by
name. Here the breaks are composed as OpticStudio defines them (order 0: decenter, then
tilt about x, y, z, each about the moved axes; order 1: tilt about z, y, x, then
decenter) and glasses are read from the catalogue the file names.

Why a short scan of the file's lines beside the parser: the parser skips operands it
does not know, and a few of those change the optics (surface tilts and decenters,
units, rectangular apertures, several configurations); the scan refuses them.

Examples
--------
Not run here (it needs a lab's file)::

    design = read_zemax_design("arm.zmx", slm_pixel_pitch_um=8.0, camera_pixel_pitch_um=5.5)
    design.surfaces[0].material
    # 'SF10'

>>> FILE_KEYS[:3]
('file', 'slm_pixel_pitch_um', 'camera_pixel_pitch_um')
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from sassi_bench.errors import ConfigError, did_you_mean, step_error
from sassi_bench.optics.design.build import require_optiland
from sassi_bench.optics.design.schema import OpticalDesign

__all__ = ["CATALOGUES", "FILE_KEYS", "design_mapping_from_file", "read_zemax_design"]

_STEP = "rig description: design.file"

#: Keys a ``design:`` section given as a file takes.
FILE_KEYS = ("file", "slm_pixel_pitch_um", "camera_pixel_pitch_um", "reference_nm", "catalogue")

#: Glass catalogues the design can read (optiland's bundled files).
CATALOGUES = ("schott", "ohara", "hoya", "cdgm", "hikari", "sumita")

# Aperture types of the parser -> the design's aperture kinds.
_APERTURES = {
    "EPD": "entrance_pupil_diameter_mm",
    "objectNA": "object_space_na",
    "paraxialImageFNO": "working_f_number",
}

# Operands the parser skips that change the optics when set (see the module's note).
_SKIPPED_SHAPES = {
    "SQAP": "a rectangular aperture",
    "ELAP": "an elliptical aperture",
    "UDAP": "a user-defined aperture",
    "SPID": "a spider aperture",
    "OBSC": "a circular obscuration",
    "OBSQ": "a rectangular obscuration",
}

# Tolerances for a coordinate break pair that restores the axis, and for the d-line
# index of a file's glass against the catalogue's (a different melt or a model glass).
_ANGLE_TOL = 1e-9
_LENGTH_TOL_MM = 1e-9
_ND_TOL = 5e-4
_D_LINE_UM = 0.5875618


def _refuse(cause: str, fix: str) -> ConfigError:
    return ConfigError(step_error(_STEP, cause, fix))


# -- the file ---------------------------------------------------------------------------
def _read_lines(path: Path) -> list[list[str]]:
    """The file's lines as tokens, in the encodings OpticStudio writes."""
    raw = path.read_bytes()
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        text = raw.decode("utf-16")
    else:
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            text = raw.decode("iso-8859-1")
    return [line.split() for line in text.splitlines() if line.split()]


def _number(token: str) -> float:
    """A numeric field (NaN when unreadable: refused as set, never taken as zero)."""
    try:
        return float(token.replace(",", "."))
    except ValueError:
        return math.nan


def _check_skipped_operands(path: Path) -> None:
    """Refuse operands the parser skips that would change the arm."""
    surface = -1
    for tokens in _read_lines(path):
        op = tokens[0]
        if op == "SURF":
            surface += 1
        elif op == "UNIT" and len(tokens) > 1 and tokens[1].upper() != "MM":
            raise _refuse(
                f"{path.name} is in {tokens[1]}, the design is in millimetres",
                "set the lens units to millimetres in the design program and save again",
            )
        elif op == "FTYP" and len(tokens) > 2 and _number(tokens[2]) != 0:
            raise _refuse(
                f"{path.name} sets telecentric object space, which the trace does not force",
                "clear the flag; the stop's place makes the arm telecentric or not",
            )
        elif op == "MNUM" and len(tokens) > 1 and not _number(tokens[1]) <= 1:
            raise _refuse(
                f"{path.name} holds {tokens[1]} configurations",
                "save the configuration of the arm to use as a file of its own",
            )
        elif op == "SCBD" and any(_number(t) != 0.0 for t in tokens[4:]):
            raise _refuse(
                f"surface {surface} of {path.name} has its own tilt or decenter, "
                "which the reader does not take",
                "write the tilt as coordinate breaks around the surface "
                "(the design program's Tilt/Decenter Elements tool) and save again",
            )
        elif op in _SKIPPED_SHAPES:
            raise _refuse(
                f"surface {surface} of {path.name} has {_SKIPPED_SHAPES[op]}",
                "give it a circular aperture (or none) in the design program",
            )


def _parse(path: Path) -> Any:
    """optiland's data model of the file (glass names kept as written)."""
    require_optiland()
    from optiland.fileio.zemax import ZemaxDataParser

    class _NamedGlassParser(ZemaxDataParser):
        """optiland's parser, keeping each glass's name and d-line index as written:
        the design reads glasses from the one catalogue it names, where the parser
        searches every catalogue by name."""

        def _read_glass(self, data: list[str]) -> None:
            name = data[1]
            self._current_surf_data["material"] = "mirror" if name.upper() == "MIRROR" else name
            try:
                self._current_surf_data["nd"] = float(data[4].replace(",", "."))
            except (IndexError, ValueError):
                self._current_surf_data["nd"] = None

    try:
        return _NamedGlassParser(str(path)).parse()
    except (ValueError, IndexError, KeyError) as exc:
        if "sequential" in str(exc):
            cause = f"{path.name} is not a sequential design (non-sequential mode)"
            fix = "save the arm in sequential mode, from the SLM to the camera"
        else:
            cause = f"the Zemax reader cannot read {path.name} ({exc})"
            fix = "save it again from the design program as a .zmx file"
        raise _refuse(cause, fix) from None


# -- coordinate breaks --------------------------------------------------------------------
def _break_move(surf: Mapping[str, Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A coordinate break as (rotation, translation) in the axes before it (columns of
    the rotation: the new axes), its thickness left out."""
    dx, dy = float(surf.get("param_0", 0.0)), float(surf.get("param_1", 0.0))
    tilt = [float(surf.get(f"param_{k}", 0.0)) for k in (2, 3, 4)]
    order = float(surf.get("param_5", 0.0))
    if order == 0.0:
        rotation = Rotation.from_euler("XYZ", tilt, degrees=True).as_matrix()
        return rotation, np.array([dx, dy, 0.0])
    rotation = Rotation.from_euler("ZYX", tilt[::-1], degrees=True).as_matrix()
    return rotation, rotation @ np.array([dx, dy, 0.0])


def _tilt_deg(rotation: NDArray[np.float64]) -> list[float]:
    tilt = Rotation.from_matrix(rotation).as_euler("XYZ", degrees=True)
    return [0.0 if abs(a) < 1e-12 else float(a) for a in tilt]


def _break_entries(surf: Mapping[str, Any]) -> list[dict[str, Any]]:
    """A coordinate break as the design's ``coordinate_break`` entries (decenter, then
    tilt; a decenter along the old axis becomes a thickness before the tilt)."""
    rotation, shift = _break_move(surf)
    thickness = float(surf.get("thickness", 0.0))
    entries = []
    if abs(shift[2]) > _LENGTH_TOL_MM:
        entries.append(
            {
                "coordinate_break": {"decenter_mm": [shift[0], shift[1]], "tilt_deg": [0, 0, 0]},
                "thickness_mm": float(shift[2]),
            }
        )
        shift = np.zeros(3)
    entries.append(
        {
            "coordinate_break": {
                "decenter_mm": [float(shift[0]), float(shift[1])],
                "tilt_deg": _tilt_deg(rotation),
            },
            "thickness_mm": thickness,
        }
    )
    return entries


def _restores(before: Mapping[str, Any], after: Mapping[str, Any]) -> bool:
    """Whether ``after`` undoes ``before`` (a surface's own tilt and decenter)."""
    r1, t1 = _break_move(before)
    r2, t2 = _break_move(after)
    rotation = r1 @ r2
    shift = t1 + r1 @ t2
    return bool(
        np.abs(rotation - np.eye(3)).max() < _ANGLE_TOL
        and np.abs(shift).max() < _LENGTH_TOL_MM
        and abs(t1[2]) < _LENGTH_TOL_MM
    )


# -- surfaces -----------------------------------------------------------------------------
def _optical_entry(index: int, surf: Mapping[str, Any], name: str) -> dict[str, Any]:
    """A standard surface as a ``design.surfaces`` entry."""
    kind = surf.get("type", "standard")
    if kind != "standard":
        raise _refuse(
            f"surface {index} of {name} is of type {kind!r}, which the design cannot trace",
            "use standard (spherical or conic) surfaces and coordinate breaks only",
        )
    material = surf.get("material", "air")
    if material == "mirror":
        raise _refuse(
            f"surface {index} of {name} is a mirror; the design has refracting surfaces only",
            "unfold the mirror (its fold becomes a coordinate break) and save again",
        )
    thickness = float(surf.get("thickness", 0.0))
    if not math.isfinite(thickness):
        raise _refuse(
            f"surface {index} of {name} has an infinite thickness",
            "give every surface between the SLM and the camera a finite thickness",
        )
    entry: dict[str, Any] = {"thickness_mm": thickness, "comment": f"{name} surface {index}"}
    radius = float(surf.get("radius", math.inf))
    if math.isfinite(radius):
        entry["radius_mm"] = radius
    if float(surf.get("conic", 0.0)):
        entry["conic"] = float(surf["conic"])
    if material != "air":
        entry["material"] = str(material)
    if surf.get("is_stop"):
        entry["stop"] = True
    aperture = surf.get("aperture")
    if aperture is not None:
        offset = (getattr(aperture, "offset_x", 0.0), getattr(aperture, "offset_y", 0.0))
        if float(aperture.r_min) > 0 or any(float(o) for o in offset):
            raise _refuse(
                f"surface {index} of {name} has an annular or decentred aperture",
                "give it a centred circular aperture (or none) in the design program",
            )
        entry["diameter_mm"] = 2.0 * float(aperture.r_max)
    return entry


def _surface_entries(surfaces: Mapping[int, Mapping[str, Any]], name: str) -> list[Any]:
    """Surfaces 1 .. N-1 as entries; the last element is the image's own break (or None)."""
    numbers = sorted(surfaces)[1:-1]
    entries: list[dict[str, Any]] = []
    i = 0
    while i < len(numbers):
        n = numbers[i]
        surf = surfaces[n]
        if surf.get("type") != "coordinate_break":
            entries.append(_optical_entry(n, surf, name))
            i += 1
            continue
        if surf.get("is_stop"):
            raise _refuse(
                f"the stop of {name} is on coordinate break {n}",
                "put the stop on an optical surface",
            )
        if i + 2 < len(numbers):
            tilted, after = surfaces[numbers[i + 1]], surfaces[numbers[i + 2]]
            if (
                float(surf.get("thickness", 0.0)) == 0.0
                and tilted.get("type") != "coordinate_break"
                and float(tilted.get("thickness", 0.0)) == 0.0
                and after.get("type") == "coordinate_break"
                and _restores(surf, after)
            ):
                entry = _optical_entry(numbers[i + 1], tilted, name)
                rotation, shift = _break_move(surf)
                entry["tilt_deg"] = _tilt_deg(rotation)
                if abs(shift[0]) > 0 or abs(shift[1]) > 0:
                    entry["decenter_mm"] = [float(shift[0]), float(shift[1])]
                entry["thickness_mm"] = float(after.get("thickness", 0.0))
                entries.append(entry)
                i += 3
                continue
        entries.extend(_break_entries(surf))
        i += 1
    return entries


def _image_section(entries: list[dict[str, Any]]) -> dict[str, Any]:
    """Take a last coordinate break of zero thickness as the camera's own tilt and
    decenter (the ``image:`` section)."""
    if not entries or "coordinate_break" not in entries[-1]:
        return {}
    last = entries[-1]
    if last["thickness_mm"] != 0.0:
        return {}
    entries.pop()
    return {
        "tilt_deg": last["coordinate_break"]["tilt_deg"],
        "decenter_mm": last["coordinate_break"]["decenter_mm"],
    }


# -- glass ----------------------------------------------------------------------------------
def _glass_file(catalogue: str, glass: str) -> Any:
    return resources.files("optiland.database").joinpath(
        "data-nk", "glass", catalogue, f"{glass}.yml"
    )


def _catalogue(
    surfaces: Mapping[int, Mapping[str, Any]], named: list[str] | None, chosen: str | None
) -> str:
    """The catalogue that holds every glass of the file, checked against the d-line index
    the file records."""
    glasses = [
        (n, s["material"], s.get("nd"))
        for n, s in sorted(surfaces.items())
        if s.get("type") != "coordinate_break" and s.get("material", "air") not in ("air", "mirror")
    ]
    if chosen is not None:
        candidates = [chosen.lower()]
    else:
        candidates = [c.lower() for c in named or [] if c.lower() in CATALOGUES] or ["schott"]
    for catalogue in candidates:
        if all(_glass_file(catalogue, g).is_file() for _, g, _ in glasses):
            break
    else:
        n, glass, _ = next(
            (n, g, d) for n, g, d in glasses if not _glass_file(candidates[0], g).is_file()
        )
        raise _refuse(
            f"glass {glass!r} (surface {n}) is not in the {', '.join(candidates)} "
            "catalogue(s) the reader has",
            f"replace it by a catalogue glass, or set design.catalogue ({', '.join(CATALOGUES)})",
        )
    from optiland.materials import MaterialFile

    for n, glass, nd in glasses:
        if nd is None or nd <= 1.0:
            continue
        index = MaterialFile(str(_glass_file(catalogue, glass))).n(_D_LINE_UM)
        index = float(np.ravel(np.asarray(index))[0])
        if abs(index - nd) > _ND_TOL:
            raise _refuse(
                f"glass {glass!r} (surface {n}) has nd {nd:.5f} in the file but "
                f"{index:.5f} in the {catalogue} catalogue (a model glass or another melt?)",
                "use the catalogue glass in the design program, or set design.catalogue",
            )
    return catalogue


# -- the design -------------------------------------------------------------------------------
def read_zemax_design(
    path: str | Path,
    *,
    slm_pixel_pitch_um: float,
    camera_pixel_pitch_um: float,
    reference_nm: float | None = None,
    catalogue: str | None = None,
) -> OpticalDesign:
    """Read a Zemax sequential file as an :class:`OpticalDesign`.

    The object surface is the SLM, the image surface the camera; the file's aperture,
    surfaces, stop, circular apertures and coordinate breaks are taken; its fields are
    not (the SLM's size sets them). The file's SHA-256 is kept as the design's
    ``file_sha256``, so the rig's hash changes whenever the file does. A coordinate
    break pair around one surface that restores the axis becomes that surface's
    ``tilt_deg`` and ``decenter_mm``; a last break of zero thickness before the image
    becomes ``image``.

    Parameters
    ----------
    path
        The ``.zmx`` file.
    slm_pixel_pitch_um, camera_pixel_pitch_um
        The physical pixel pitches (the file holds none).
    reference_nm
        The wavelength the design is centred at (default: the file's primary).
    catalogue
        The glass catalogue (default: the first the file names that holds its glasses).

    Raises
    ------
    ConfigError
        When the file is missing or holds what the design cannot reproduce: another
        surface type, a mirror, a glass the catalogue lacks, a non-sequential file, an
        object or image plane the bench does not have.

    Examples
    --------
    Not run here (it needs a lab's file)::

        read_zemax_design("arm.zmx", slm_pixel_pitch_um=8.0, camera_pixel_pitch_um=5.5).aperture
        # ('object_space_na', 0.04)

    >>> try:
    ...     read_zemax_design("lost.zmx", slm_pixel_pitch_um=8.0, camera_pixel_pitch_um=5.5)
    ... except ConfigError as exc:
    ...     print(exc)  # doctest: +ELLIPSIS
    rig description: design.file: lost.zmx does not exist. Fix: check the path ...
    """
    path = Path(path)
    if not path.is_file():
        raise _refuse(f"{path} does not exist", "check the path (relative to the rig's YAML)")
    _check_skipped_operands(path)
    model = _parse(path)
    name = path.name
    surfaces = model.surfaces
    if len(surfaces) < 3:
        raise _refuse(f"{name} has no surfaces between object and image", "check the file")
    numbers = sorted(surfaces)
    obj, image = surfaces[numbers[0]], surfaces[numbers[-1]]
    distance = float(obj.get("thickness", 0.0))
    if not (math.isfinite(distance) and distance > 0) or math.isfinite(
        float(obj.get("radius", math.inf))
    ):
        raise _refuse(
            f"the object of {name} is not a flat plane at a finite distance (thickness {distance})",
            "put the SLM at the object surface: flat, at its distance from the first surface",
        )
    if math.isfinite(float(image.get("radius", math.inf))) or image.get("type") != "standard":
        raise _refuse(
            f"the image surface of {name} is not a flat plane",
            "make the image surface flat (the camera's sensor)",
        )
    ((kind, value),) = list(model.aperture.items())[:1] or [("none", 0.0)]
    if kind not in _APERTURES:
        raise _refuse(
            f"the system aperture of {name} is {kind!r}",
            "set it to entrance pupil diameter, object space NA or paraxial working F/#",
        )
    if model.fields.get("afocal_image_space"):
        raise _refuse(
            f"{name} has an afocal image space; the camera needs an image plane",
            "clear the afocal image space flag and end the arm at the camera",
        )
    entries = _surface_entries(surfaces, name)
    image_section = _image_section(entries)
    chosen = _catalogue(surfaces, model.glass_catalogs, catalogue)
    if reference_nm is None:
        waves = model.wavelengths
        primary = waves.get("primary_index")
        data = waves.get("data") or []
        reference_nm = 1e3 * float(data[primary]) if primary is not None and data else 550.0
    mapping: dict[str, Any] = {
        "slm_pixel_pitch_um": slm_pixel_pitch_um,
        "camera_pixel_pitch_um": camera_pixel_pitch_um,
        "object_distance_mm": distance,
        "aperture": {_APERTURES[kind]: float(value)},
        "surfaces": entries,
        "reference_nm": float(reference_nm),
        "catalogue": chosen,
        "file_sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
    }
    if image_section:
        mapping["image"] = image_section
    try:
        return OpticalDesign.from_mapping(mapping)
    except ConfigError as exc:
        raise _refuse(f"{name} does not make a valid design: {exc}", "correct the file") from None


def design_mapping_from_file(section: Mapping[str, Any], folder: str | Path) -> dict[str, Any]:
    """A rig's ``design: {file: ...}`` section as the ``design.surfaces`` keys it means.

    ``file`` is resolved against ``folder`` (the rig YAML's) when relative.

    Examples
    --------
    >>> try:
    ...     design_mapping_from_file({"file": "arm.zmx", "surfaces": []}, ".")
    ... except ConfigError as exc:
    ...     print(exc)  # doctest: +ELLIPSIS
    rig description: design.file: design.surfaces: not taken beside design.file. Fix: use file, ...
    """
    for key in section:
        if key not in FILE_KEYS:
            raise _refuse(
                f"design.{key}: not taken beside design.file{did_you_mean(key, FILE_KEYS)}",
                f"use {', '.join(FILE_KEYS)}; the rest comes from the file",
            )
    for key in ("slm_pixel_pitch_um", "camera_pixel_pitch_um"):
        if key not in section:
            raise _refuse(f"design.{key} is missing", "add it beside design.file")
    path = Path(str(section["file"])).expanduser()
    if not path.is_absolute():
        path = Path(folder) / path
    design = read_zemax_design(
        path,
        slm_pixel_pitch_um=float(section["slm_pixel_pitch_um"]),
        camera_pixel_pitch_um=float(section["camera_pixel_pitch_um"]),
        reference_nm=section.get("reference_nm"),
        catalogue=section.get("catalogue"),
    )
    return design.to_mapping()
