"""An :class:`~sassi_bench.optics.design.schema.OpticalDesign` as an optiland optic.

optiland (MIT) is the ray tracer: vectorised real-ray tracing with iterative ray aiming,
per-surface tilts and decenters and the refractiveindex.info glass catalogues bundled
offline. It is an optional extra (``pip install "sassi-bench[design]"``), imported only
here and only when a design is traced (the import takes seconds).

Why the build places every surface by absolute coordinates: optiland's relative mode
does not chain tilts to later surfaces, so coordinate breaks are resolved here into
global frames. Why a flat dummy surface before the first one: optiland's object-height
fields need the system entered along +z, which a tilted or decentred first surface
breaks. Why glasses are read from their exact catalogue file: optiland's name search
finds "SF10" ambiguous (SF10 and N-SF10) and resolves some names in another maker's
catalogue without an error.
"""

from __future__ import annotations

import difflib
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.optics.design.schema import OpticalDesign

__all__ = ["INSTALL_HINT", "BuiltDesign", "build_design", "require_optiland"]

#: How to install the ray tracer.
INSTALL_HINT = 'pip install "sassi-bench[design]"'


def require_optiland() -> Any:
    """Import optiland, or raise a :class:`ConfigError` that says how to install it.

    Examples
    --------
    >>> try:
    ...     _ = require_optiland()
    ... except ConfigError as exc:
    ...     assert "sassi-bench[design]" in str(exc)
    """
    try:
        import optiland.optic
    except ImportError:
        raise ConfigError(
            step_error(
                "optical design",
                "tracing a design: section needs the optiland ray tracer, which is not installed",
                f"install it with {INSTALL_HINT}",
            )
        ) from None
    # Every first-order call on a tilted system warns that its scalar (paraxial) results
    # treat surfaces as centred; real rays are exact, and only the stop radius used for
    # ray aiming comes from first order.
    warnings.filterwarnings("ignore", message=".*scalar first-order.*")
    warnings.filterwarnings("ignore", module="optiland.paraxial_path")
    return optiland


def _rotation(tilt_deg: Any) -> NDArray[np.float64]:
    """Tilts about x, then y, then z, each about the moved axes (columns: new axes)."""
    return Rotation.from_euler("XYZ", np.asarray(tilt_deg, float), degrees=True).as_matrix()


@dataclass(frozen=True)
class _Frame:
    origin: NDArray[np.float64]
    axes: NDArray[np.float64]  # columns: local x, y, z in global coordinates


@dataclass(frozen=True)
class _Placed:
    index: int
    frame: _Frame
    radius: float
    conic: float
    material: str
    stop: bool
    diameter: float | None
    comment: str


class BuiltDesign:
    """A design placed in space and built as an optiland ``Optic``.

    Parameters
    ----------
    design
        The described (or as-built) design.
    slm_shape, camera_shape
        (height, width) of the SLM and the spectral camera, pixels.

    Attributes
    ----------
    optic
        The optiland ``Optic`` (object: the SLM; image: the camera plane).
    max_field_mm
        The object height that normalised field 1 means.
    """

    def __init__(
        self, design: OpticalDesign, slm_shape: tuple[int, int], camera_shape: tuple[int, int]
    ) -> None:
        require_optiland()
        self.design = design
        self.slm_shape = slm_shape
        self.camera_shape = camera_shape
        self.p_slm = design.slm_pixel_pitch_um * 1e-3
        self.p_cam = design.camera_pixel_pitch_um * 1e-3
        self.reference_um = design.reference_nm * 1e-3
        h, w = slm_shape
        # a little beyond the corners: the traced grid reaches past the SLM's edges
        self.max_field_mm = 1.3 * math.hypot(0.5 * (w - 1) * self.p_slm, 0.5 * (h - 1) * self.p_slm)
        self._materials: dict[str, Any] = {}
        placed, self.image_frame = self._place()
        self.optic = self._optic(placed, self.image_frame)

    # -- glass --------------------------------------------------------------------------
    def material(self, name: str) -> Any:
        """The catalogue glass ``name`` from the exact file optiland bundles."""
        from importlib import resources

        from optiland.materials import MaterialFile

        if name not in self._materials:
            catalogue = self.design.catalogue
            root = resources.files("optiland.database").joinpath("data-nk", "glass", catalogue)
            path = root.joinpath(f"{name}.yml")
            if not path.is_file():
                known = sorted(p.name[:-4] for p in root.iterdir() if p.name.endswith(".yml"))
                close = difflib.get_close_matches(name, known, n=3)
                raise ConfigError(
                    step_error(
                        "rig description: design",
                        f"glass {name!r} is not in the {catalogue} catalogue"
                        + (f" (closest: {', '.join(close)})" if close else ""),
                        "check the spelling or set design.catalogue "
                        "(schott, ohara, hoya, cdgm, hikari, sumita)",
                    )
                )
            self._materials[name] = MaterialFile(str(path))
        return self._materials[name]

    # -- placement ----------------------------------------------------------------------
    def _place(self) -> tuple[list[_Placed], _Frame]:
        """Every surface's global frame; ``coordinate_break: chief_ray`` solved."""
        design = self.design
        origin = np.array([0.0, 0.0, design.object_distance_mm])
        axes = np.eye(3)
        placed: list[_Placed] = []
        for i, s in enumerate(design.surfaces, 1):
            if s.is_break:
                if s.coordinate_break == "chief_ray":
                    origin, axes = self._chief_ray_axis(placed, _Frame(origin, axes))
                else:
                    dx, dy = s.coordinate_break["decenter_mm"]
                    origin = origin + axes @ np.array([dx, dy, 0.0])
                    axes = axes @ _rotation(s.coordinate_break["tilt_deg"])
            else:
                dx, dy = s.decenter_mm
                frame = _Frame(
                    origin + axes @ np.array([dx, dy, 0.0]), axes @ _rotation(s.tilt_deg)
                )
                if s.material != "air":
                    self.material(s.material)
                radius = np.inf if s.radius_mm is None else s.radius_mm
                placed.append(
                    _Placed(i, frame, radius, s.conic, s.material, s.stop, s.diameter_mm, s.comment)
                )
            origin = origin + axes @ np.array([0.0, 0.0, s.thickness_mm])
        dx, dy = design.image_decenter_mm
        image = _Frame(
            origin + axes @ np.array([dx, dy, 0.0]), axes @ _rotation(design.image_tilt_deg)
        )
        return placed, image

    def _optic(self, placed: list[_Placed], image: _Frame) -> Any:
        from optiland.optic import Optic

        optic = Optic()
        optic.surfaces.add(index=0, x=0.0, y=0.0, z=0.0, material="air")  # the SLM
        entry_z = 0.5 * self.design.object_distance_mm
        optic.surfaces.add(index=1, x=0.0, y=0.0, z=entry_z, comment="entry (dummy)")
        for k, s in enumerate(placed, 2):
            rx, ry, rz = Rotation.from_matrix(s.frame.axes).as_euler("xyz")  # optiland: Rz Ry Rx
            kwargs: dict[str, Any] = {
                "index": k,
                "x": float(s.frame.origin[0]),
                "y": float(s.frame.origin[1]),
                "z": float(s.frame.origin[2]),
                "rx": float(rx),
                "ry": float(ry),
                "rz": float(rz),
                "radius": float(s.radius),
                "conic": float(s.conic),
                "is_stop": s.stop,
                "material": "air" if s.material == "air" else self.material(s.material),
                "comment": s.comment or f"surface {s.index}",
            }
            if s.diameter is not None:
                kwargs["aperture"] = float(s.diameter)
            optic.surfaces.add(**kwargs)
        rx, ry, rz = Rotation.from_matrix(image.axes).as_euler("xyz")
        optic.surfaces.add(
            index=len(placed) + 2,
            x=float(image.origin[0]),
            y=float(image.origin[1]),
            z=float(image.origin[2]),
            rx=float(rx),
            ry=float(ry),
            rz=float(rz),
            comment="camera",
        )
        optic.fields.set_type("object_height")
        optic.fields.add(y=0.0, x=0.0)
        optic.fields.add(y=self.max_field_mm, x=0.0)
        optic.wavelengths.add(value=self.reference_um, is_primary=True)
        kind, value = self.design.aperture
        if kind == "object_space_na":
            optic.set_aperture("objectNA", value)
        elif kind == "entrance_pupil_diameter_mm":
            optic.set_aperture("EPD", value)
        else:  # a working F-number, through the paraxial magnification
            optic.set_aperture("objectNA", 0.05)
            magnification = abs(float(optic.paraxial.magnification()))
            optic.set_aperture("objectNA", magnification / (2.0 * value))
        optic.ray_tracer.set_aiming("iterative", max_iter=30, tol=1e-10)
        return optic

    def _chief_ray_axis(
        self, placed: list[_Placed], plane: _Frame
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Where and along what the on-axis chief ray crosses ``plane``."""
        if not any(s.stop for s in placed):
            raise ConfigError(
                step_error(
                    "rig description: design",
                    "coordinate_break: chief_ray comes before the stop",
                    "mark the stop on a surface before the break",
                )
            )
        optic = self._optic(placed, plane)
        rays = optic.trace_generic(0.0, 0.0, 0.0, 0.0, self.reference_um)
        point = np.array(
            [float(np.ravel(rays.x)[0]), float(np.ravel(rays.y)[0]), float(np.ravel(rays.z)[0])]
        )
        d = np.array(
            [float(np.ravel(rays.L)[0]), float(np.ravel(rays.M)[0]), float(np.ravel(rays.N)[0])]
        )
        if not np.all(np.isfinite(point)):
            raise ConfigError(
                step_error(
                    "rig description: design",
                    "coordinate_break: chief_ray: the on-axis chief ray does not reach the break",
                    "check the prism's tilts (total internal reflection?) and the diameters",
                )
            )
        x_old = plane.axes[:, 0]
        x_new = x_old - (x_old @ d) * d
        x_new /= np.linalg.norm(x_new)
        return point, np.column_stack([x_new, np.cross(d, x_new), d])

    # -- rays -----------------------------------------------------------------------------
    def field_of(self, u: NDArray[np.float64], v: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """Normalised field (Hx, Hy) of SLM pixels (u, v)."""
        h, w = self.slm_shape
        x = (np.asarray(u, float) - 0.5 * (w - 1)) * self.p_slm
        y = (np.asarray(v, float) - 0.5 * (h - 1)) * self.p_slm
        return x / self.max_field_mm, y / self.max_field_mm

    def trace(
        self, hx: NDArray, hy: NDArray, px: NDArray, py: NDArray, wavelength_nm: float
    ) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """Trace rays; camera (x, y) px, whether each arrived, and their direction (L, M)
        in the camera plane's axes."""
        rays = self.optic.trace_generic(hx, hy, px, py, wavelength_nm * 1e-3)
        points = np.stack([np.asarray(rays.x), np.asarray(rays.y), np.asarray(rays.z)], axis=-1)
        dirs = np.stack([np.asarray(rays.L), np.asarray(rays.M), np.asarray(rays.N)], axis=-1)
        frame = self.image_frame
        local = (points - frame.origin) @ frame.axes
        local_dir = dirs @ frame.axes
        hc, wc = self.camera_shape
        x = 0.5 * (wc - 1) + local[..., 0] / self.p_cam
        y = 0.5 * (hc - 1) + local[..., 1] / self.p_cam
        alive = (np.asarray(rays.i) > 0) & np.isfinite(x) & np.isfinite(y)
        return x, y, alive, local_dir[..., 0], local_dir[..., 1]


def build_design(
    design: OpticalDesign, slm_shape: tuple[int, int], camera_shape: tuple[int, int]
) -> BuiltDesign:
    """Place ``design`` and build it as an optiland optic (see :class:`BuiltDesign`)."""
    return BuiltDesign(design, slm_shape, camera_shape)
