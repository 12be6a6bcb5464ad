"""Plan-time check of a pinhole scan's pitch against the streaks' length and blur.

A pinhole scan's background is the mean, per camera pixel, over the frames in which no
streak reaches it (:mod:`~sassi_bench.spectra.scan`); the reading pass marks each streak
from its 400 nm edge to its 700 nm edge, widened by 6 camera px and 4 blur sigmas at each
end (:data:`FOOTPRINT_MARGIN_PX`, :data:`FOOTPRINT_SIGMAS`: the reach the scan's reading
pass gives :func:`~sassi_bench.spectra.offset.footprint_rectangles`, one constant for
both). If neighbouring pinholes of a row are closer on the camera than that footprint plus
one SLM pixel's image, some camera columns are under a streak in every frame: their
background can only be guessed from around, and the scan's spectra there carry the error.
A plan whose streaks overlap so is refused before anything is captured (an
example rig: ``tests/rigs/prism-sf10-80px.yaml``).

Judged from the rig's description (a ray trace of the described relay and prism, the
described blur), as :func:`~sassi_bench.acquire.spectral_plans.check_lamp_pitch` does
for the lamp frames, on a grid of field points: a lab's prism and relay are known before
any calibration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.optics.psf import PsfSigmaCurve, line_spread_sigma
from sassi_bench.rig.config import RigDescription

__all__ = [
    "FOOTPRINT_MARGIN_PX",
    "FOOTPRINT_SIGMAS",
    "PitchRoom",
    "check_scan_pitch",
    "described_spot_sigma",
    "pitch_room",
    "scan_pitch_room",
]

#: The streak's footprint in a scan's reading pass: camera px beyond each end of the band,
#: and blur sigmas at each end. The reading pass marks this reach
#: (:data:`~sassi_bench.spectra.scan.FOOTPRINT_REACH` is these two), so the pitch checked
#: here is the pitch the scan's background needs, not a narrower one whose footprints, as
#: the scan marks them, overlap (``docs/notes/2026-12-01-measured-in-code-comments.md``).
FOOTPRINT_MARGIN_PX = 6.0
FOOTPRINT_SIGMAS = 4.0

#: The band every streak is marked over (nm).
BAND_NM = (400.0, 700.0)

#: Field points (along u, along v) at which the room is judged.
FIELD_POINTS = (9, 5)


@dataclass(frozen=True)
class PitchRoom:
    """How a pinhole pitch fits the streaks, at the tightest field point.

    Attributes
    ----------
    footprint_px
        Camera columns one streak's footprint spans there (band, margins and blur).
    distance_px
        Camera columns between neighbouring pinholes of a row there.
    step_px
        Camera columns one SLM pixel moves a streak there.
    needed_pitch
        The smallest horizontal pitch (SLM px) that leaves every camera column free of
        streaks in at least one frame.
    """

    footprint_px: float
    distance_px: float
    step_px: float
    needed_pitch: int

    @property
    def room_px(self) -> float:
        """Streak-free camera columns between neighbouring footprints."""
        return self.distance_px - self.footprint_px

    @property
    def fits(self) -> bool:
        """Every camera column is free of streaks in at least one pinhole offset."""
        return self.room_px >= self.step_px


def described_spot_sigma(desc: RigDescription, wavelength_nm) -> np.ndarray:
    """Sigma (camera px) of one SLM pixel's spot at some wavelengths, as described: the
    described PSF, the SLM pixel's image and the camera pixel
    (:func:`~sassi_bench.optics.psf.line_spread_sigma`).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> [round(float(s), 2) for s in described_spot_sigma(load_rig_description("sim"), [400, 550])]
    [1.86, 0.65]
    """
    return line_spread_sigma(
        PsfSigmaCurve(desc.blur.sigma_px)(np.asarray(wavelength_nm, dtype=np.float64)),
        desc.relay.scale,
        desc.slm.fill_factor,
    )


def _room(
    desc: RigDescription,
    pitch_u: int,
    band: tuple[float, float],
    reach_sigmas: float,
    margin_px: float,
) -> tuple[float, float, float]:
    """Footprint, distance and one pixel's step (camera px) at the tightest field point."""
    relay = desc.nominal_relay()
    h, w = desc.slm.height, desc.slm.width
    last = max(w - 1 - pitch_u, 0)
    v, u = np.meshgrid(
        np.linspace(0.0, h - 1, FIELD_POINTS[1]), np.linspace(0.0, last, FIELD_POINTS[0])
    )
    u, v = u.ravel()[:, None], v.ravel()[:, None]
    ends = np.asarray(band, dtype=np.float64)[None, :]
    x, _ = relay.forward(u, v, ends)
    right, _ = relay.forward(u + pitch_u, v, ends)
    one, _ = relay.forward(u + 1.0, v, ends)
    spot = described_spot_sigma(desc, band)
    footprint = np.abs(x[:, 1] - x[:, 0]) + 2.0 * margin_px + reach_sigmas * float(spot.sum())
    step = np.abs(one[:, 0] - x[:, 0])
    distance = np.abs(right[:, 0] - x[:, 0])
    worst = int(np.argmin(distance - footprint - step))
    return float(footprint[worst]), float(distance[worst]), float(step[worst])


def pitch_room(
    desc: RigDescription,
    pitch_u: int,
    band: tuple[float, float] = BAND_NM,
    reach_sigmas: float = FOOTPRINT_SIGMAS,
    margin_px: float = FOOTPRINT_MARGIN_PX,
) -> PitchRoom:
    """The room a horizontal pinhole pitch leaves between streaks of a band, each marked
    ``reach_sigmas`` spot sigmas and ``margin_px`` camera px beyond the band's ends.

    ``needed_pitch`` is the smallest pitch that leaves room (the SLM's width when none
    does). :func:`scan_pitch_room` is this for a scan's 400-700 nm footprint; the lamp
    frames ask it for their lines' band.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> room = pitch_room(load_rig_description("sim"), 100, (404.7, 706.7), 4.0, 1.0)
    >>> room.fits, room.needed_pitch
    (True, 87)
    """
    footprint, distance, step = _room(desc, int(pitch_u), band, reach_sigmas, margin_px)
    needed = max(1, math.ceil((footprint + step) / step) - 2)
    while needed < desc.slm.width:  # from just under the linear estimate, a few steps
        f, d, s = _room(desc, needed, band, reach_sigmas, margin_px)
        if d - f >= s:
            break
        needed += 1
    return PitchRoom(footprint, distance, step, int(needed))


def scan_pitch_room(desc: RigDescription, pitch_u: int) -> PitchRoom:
    """The room a horizontal pinhole pitch leaves between the streaks' footprints, as the
    scan's reading pass marks them (400-700 nm, :data:`FOOTPRINT_SIGMAS` and
    :data:`FOOTPRINT_MARGIN_PX` beyond each end).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> room = scan_pitch_room(load_rig_description("sim"), 100)
    >>> room.fits, round(room.room_px, 1), room.needed_pitch
    (True, 4.6, 97)
    """
    return pitch_room(desc, pitch_u)


def check_scan_pitch(desc: RigDescription, pitch: tuple[int, int], what: str = "scan") -> None:
    """Refuse a pinhole pitch whose streaks, with their blur, leave some camera columns
    under a streak in every frame (so no background can be measured there).

    Parameters
    ----------
    desc
        The rig's description (its relay, prism, blur and SLM).
    pitch
        (horizontal, vertical) pinhole pitch in SLM px.
    what
        The scan, as the error names it (``"response scan"``, ``"Macbeth scan"``...).

    Raises
    ------
    ProcedureError
        Naming the streak's footprint, the pinholes' distance and both fixes.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> check_scan_pitch(load_rig_description("sim"), (100, 5))
    >>> check_scan_pitch(load_rig_description("sim"), (80, 5))
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: pinhole scan: ... Fix: ...
    """
    room = scan_pitch_room(desc, int(pitch[0]))
    if room.fits:
        return
    bound = room.distance_px - room.step_px - 2.0 * FOOTPRINT_MARGIN_PX
    raise ProcedureError(
        step_error(
            "pinhole scan",
            f"the {what}'s streaks leave no streak-free camera columns at a pitch of "
            f"{int(pitch[0])} SLM px: each streak with its blur spans {room.footprint_px:.1f} "
            f"camera px (400-700 nm over prism.spread_px, {FOOTPRINT_MARGIN_PX:g} px and "
            f"{FOOTPRINT_SIGMAS:g} blur sigmas at each end) while neighbouring pinholes of a "
            f"row are {room.distance_px:.1f} camera px apart at the tightest field point, so "
            "some columns are under a streak in every frame and their background cannot be "
            "measured",
            f"scan at a horizontal pitch of at least {room.needed_pitch} SLM px (the "
            f"procedure's pitch_px), or shorten the streak (a prism that disperses less, a "
            f"lower relay scale) so that it spans under {bound:.0f} camera px with its blur",
        )
    )
