"""Spectral arms described as optical designs, ray-traced by optiland.

A rig's ``design:`` section gives the arm from the SLM to the spectral camera as
sequential surfaces (:mod:`.schema`); it is built as an optiland optic (:mod:`.build`,
the optional extra ``sassi-bench[design]``), traced on a grid over the SLM and the band
(:mod:`.trace`), kept on disk by its hash (:mod:`.cache`) and read through smooth
interpolants (:mod:`.interp`) as a relay with spots (:mod:`.relay`). A design may also be
read from a Zemax OpticStudio file (:mod:`.zemax`, ``design: {file: arm.zmx}``).

:func:`design_relay` is the one call: a design and the rig's shapes and band in, a
:class:`~sassi_bench.optics.design.relay.DesignRelay` out (traced once, then read from
the cache). :func:`nominal_summary` condenses a relay to the parametric numbers the rest
of a description is checked with (scale, the prism, the widest spot per wavelength).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from sassi_bench.optics.design.cache import cache_folder, cache_key, cached_trace
from sassi_bench.optics.design.relay import DesignRelay
from sassi_bench.optics.design.schema import OpticalDesign, Surface, with_override
from sassi_bench.optics.design.trace import GridSpec

__all__ = [
    "DesignRelay",
    "GridSpec",
    "NominalSummary",
    "OpticalDesign",
    "Surface",
    "cache_folder",
    "design_relay",
    "grid_spec",
    "nominal_summary",
    "with_override",
]

#: Wavelengths the widest spot is summarised at (nm).
SUMMARY_NM = (400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0)


def grid_spec(
    slm_shape: tuple[int, int], camera_shape: tuple[int, int], band_nm: tuple[float, float]
) -> GridSpec:
    """The grid a rig's design is traced on: 17 x 11 field nodes, 10 nm steps a node
    beyond the band on each side, 64 pupil rays per point.

    Examples
    --------
    >>> grid_spec((400, 640), (512, 800), (390.0, 720.0)).wavelengths_nm()[[0, -1]].tolist()
    [380.0, 730.0]
    """
    start = 10.0 * np.floor(band_nm[0] / 10.0) - 10.0
    stop = 10.0 * np.ceil(band_nm[1] / 10.0) + 10.0
    return GridSpec(slm_shape, camera_shape, float(start), float(stop), 10.0)


def _print_progress(done: int, total: int) -> None:
    """One line on stderr, redrawn on a terminal (the trace runs once per design)."""
    if sys.stderr.isatty():
        end = "\n" if done == total else "\r"
    elif done in (1, total):
        end = "\n"
    else:
        return
    text = f"tracing the optical design (once; then cached): {done}/{total} wavelengths"
    print(text, end=end, file=sys.stderr, flush=True)


def design_relay(
    design: OpticalDesign,
    slm_shape: tuple[int, int],
    camera_shape: tuple[int, int],
    band_nm: tuple[float, float],
    progress: Callable[[int, int], None] | None = _print_progress,
) -> DesignRelay:
    """The traced design as a relay with spots (traced once, then read from the cache).

    Parameters
    ----------
    design
        The design (as described, or as built).
    slm_shape, camera_shape
        (height, width) of the SLM and the spectral camera.
    band_nm
        The wavelengths the rig renders (its spectral grid's start and stop).
    progress
        Called with (wavelengths traced, wavelengths) while tracing; None is quiet.
    """
    spec = grid_spec(slm_shape, camera_shape, band_nm)
    key = (cache_key(design, spec), str(cache_folder()))
    relay = _RELAYS.get(key)
    if relay is None:
        grid = cached_trace(design, spec, progress=progress)
        relay = DesignRelay(
            grid, slm_shape, camera_shape, design.camera_pixel_pitch_um, design.reference_nm
        )
        if len(_RELAYS) >= 8:
            _RELAYS.clear()
        _RELAYS[key] = relay
    return relay


# Relays built in this process, by cache key: a description loaded again (every command
# loads its rig) reuses the interpolants. A relay is read-only once built.
_RELAYS: dict[tuple[str, str], DesignRelay] = {}


@dataclass(frozen=True)
class NominalSummary:
    """A design condensed to the numbers a parametric description gives.

    ``scale`` camera px per SLM px; ``offset_px`` the SLM centre's image at the
    reference wavelength from the camera's centre (x, y); ``apex_deg`` the prism's apex;
    ``spread_px`` and ``smile_px`` the 400-700 nm streak's length and row drop at the
    field centre;
    ``sigma_px`` the optics' widest spot sigma over the field at :data:`SUMMARY_NM`.
    """

    scale: float
    offset_px: tuple[float, float]
    glass: str
    apex_deg: float
    spread_px: float
    smile_px: float
    sigma_px: dict[float, float]


def _normal(surface: Surface) -> np.ndarray:
    axes = Rotation.from_euler("XYZ", surface.tilt_deg, degrees=True).as_matrix()
    return axes[:, 2]


def nominal_summary(design: OpticalDesign, relay: DesignRelay) -> NominalSummary:
    """Condense a traced design (see :class:`NominalSummary`)."""
    surfaces = [s for s in design.surfaces if not s.is_break]
    glass = design.dispersing_glass
    entry = next(i for i, s in enumerate(surfaces) if s.is_tilted and s.material == glass)
    exit_face = surfaces[entry + 1] if entry + 1 < len(surfaces) else surfaces[entry]
    cosine = float(np.clip(_normal(surfaces[entry]) @ _normal(exit_face), -1.0, 1.0))
    apex = float(np.degrees(np.arccos(cosine)))
    cu, cv = relay.slm_centre
    x, y = relay.forward(cu, cv, np.array([400.0, 700.0]))
    widest = relay.widest_sigma(np.array(SUMMARY_NM))
    xr, yr = relay.forward(cu, cv, design.reference_nm)
    hc, wc = relay.camera_shape
    return NominalSummary(
        scale=relay.scale,
        offset_px=(float(xr) - (wc - 1) / 2.0, float(yr) - (hc - 1) / 2.0),
        glass=glass,
        apex_deg=apex,
        spread_px=float(x[1] - x[0]),
        smile_px=float(y[1] - y[0]),
        sigma_px={lam: float(s) for lam, s in zip(SUMMARY_NM, widest, strict=True)},
    )
