"""What the blur pinhole frames measure: the sweep's frames with the blur step's added.

The sweep session holds ``blur.frames`` pinhole frames of every laser; the blur step
(``<id>-blur``, :func:`~sassi_bench.acquire.spectral_plans.blur_plan`) may add more, until
the field blur's stated width 1-sigma meets its tolerance
(:mod:`~sassi_bench.reduce.blur_budget`). :func:`pinhole_signals` averages both into one
signal per laser; :class:`BlurMeasurement` fits the blur from a number of frames, so the
step can measure after every batch and the analysis fits the frames it kept.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sassi_bench.acquire.session import Session
from sassi_bench.calibrate.blur import BlurFit
from sassi_bench.calibrate.dispersion import LaserMap, fit_dispersion
from sassi_bench.reduce.lamps import lamp_field_spots
from sassi_bench.reduce.sweep_stream import PinholeSignal
from sassi_bench.reduce.sweeps import blur_form, blur_from_pinholes, pinhole_signal
from sassi_bench.rig.config import RigDescription

__all__ = ["BlurMeasurement", "captured_blur_frames", "pinhole_signals"]


def captured_blur_frames(session: Session) -> int:
    """Pinhole frames per laser the sweep and a blur session hold together: the largest
    ``n`` whose first ``n`` frames of every laser are all stored.

    Examples
    --------
    Not run here (it needs a captured session)::

        captured_blur_frames(Session.open("lab-2026-11-22-blur"))
        # 4
    """
    plan, done = session.plan, session.completed
    first = int(plan.parameters.get("sweep_frames", 0))
    planned = 1 + max((int(step.tags["frame"]) for step in plan.steps), default=first - 1)
    missing = [int(plan.steps[i].tags["frame"]) for i in range(len(plan)) if i not in done]
    return min(missing, default=planned)


def pinhole_signals(
    sweep: Session,
    saturation: float,
    pinholes: Mapping[float, PinholeSignal] | None = None,
    blur: Session | None = None,
    frames: int | None = None,
) -> dict[float, PinholeSignal] | None:
    """Every laser's pinhole signal from the sweep's frames and a blur session's first
    ``frames`` (sweep's included; None: all it holds).

    Parameters
    ----------
    sweep
        The sweep session (its pinhole and blur-blank frames).
    saturation
        Raw value at which the spectral camera saturates.
    pinholes
        The sweep's pinhole signals, averaged as it was captured (None: read).
    blur
        The blur step's session; None returns ``pinholes`` as given.
    frames
        Pinhole frames per laser to use, the sweep's included.

    Returns
    -------
    dict or None
        By laser; the signals are means over every frame used, less the blank frame.

    Examples
    --------
    Not run here (it needs captured sessions)::

        pinhole_signals(sweeps.sweep, 65535, None, sweeps.blur, frames=4)[532.0].signal
    """
    if blur is None:
        return None if pinholes is None else dict(pinholes)
    first = int(blur.plan.parameters.get("sweep_frames", 0))
    frames = captured_blur_frames(blur) if frames is None else int(frames)
    out = {}
    for step in sweep.plan.steps:
        if step.tags.get("role") != "pinholes" or float(step.tags["laser"]) in out:
            continue
        laser = float(step.tags["laser"])
        known = (pinholes or {}).get(laser) or pinhole_signal(sweep, laser, saturation)
        added = [
            i
            for i in blur.plan.select(role="pinholes", laser=laser)
            if int(blur.plan.steps[i].tags["frame"]) < frames
        ]
        if not added:
            out[laser] = known
            continue
        blank_index = sweep.plan.select(role="blur-blank", laser=laser)
        blank = sweep.read_frames(blank_index).astype(np.float32).mean(axis=0)
        extra = blur.read_frames(added).astype(np.float32)
        signal = (first * known.signal + (extra - blank).sum(axis=0)) / (first + len(added))
        saturated = known.saturated | (extra >= saturation).any(axis=0)
        out[laser] = PinholeSignal(signal.astype(np.float32), saturated)
    return out


class BlurMeasurement:
    """The blur fitted from the sweep's pinhole frames and a blur session's first frames.

    The spots are placed by a dispersion fit at the lasers' labels, made once.

    Parameters
    ----------
    sweep, procedure, desc
        The sweep session, the (planned) procedure and the rig's description.
    maps
        Every swept laser's map (the sweep's decode).
    pinholes
        The sweep's pinhole signals, averaged as it was captured (None: read).
    field_degree, order
        The dispersion fit's shape (``fit.field_degree``, ``fit.dispersion_order``).

    Examples
    --------
    Not run here (it needs captured sessions)::

        measurement = BlurMeasurement(sweep, proc, desc, maps)
        measurement.fit(None, 2).width_sigma_px
        # 0.051
    """

    def __init__(
        self,
        sweep: Session,
        procedure: Mapping[str, Any],
        desc: RigDescription,
        maps: Sequence[LaserMap],
        pinholes: Mapping[float, PinholeSignal] | None = None,
        *,
        field_degree: int = 5,
        order: int = 2,
    ) -> None:
        self.sweep, self.procedure, self.desc = sweep, procedure, desc
        self.pinholes = pinholes
        self.slm_shape = (desc.slm.height, desc.slm.width)
        self.saturation = 2**desc.spectral_camera.bit_depth - 1
        shape = {"field_degree": field_degree, "order": order}
        self.start = fit_dispersion(maps, desc.prism.glass, self.slm_shape, **shape)
        self.lasers_nm = [m.wavelength_nm for m in maps]

    def fit(
        self,
        blur: Session | None,
        frames: int | None,
        lamps: Session | None = None,
        lamp_frames: int | None = None,
    ) -> BlurFit:
        """The blur from the sweep's frames and ``blur``'s up to ``frames`` per laser
        (None: all it holds), with the lamp lines' spots of ``lamps``' first
        ``lamp_frames`` field frames per offset
        (:func:`~sassi_bench.reduce.lamps.lamp_field_spots`) when a lamp session is given.
        """
        signals = pinhole_signals(self.sweep, self.saturation, self.pinholes, blur, frames)
        spots = None
        if lamps is not None:
            model = self.start.model
            spots = lamp_field_spots(lamps, self.desc, model, self.lasers_nm, lamp_frames)
        return blur_from_pinholes(
            self.sweep, self.procedure, self.start, self.slm_shape, self.saturation, signals,
            self.desc.slm.fill_factor, form=blur_form(self.procedure, self.desc),
            laser_fwhm_nm=self.desc.light.laser_fwhm_nm, lamp_spots=spots,
        )  # fmt: skip
