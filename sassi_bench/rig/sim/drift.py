"""The virtual bench's optics drifting with time (``nuisance.drift``, bench-only).

A real bench does not hold still: the relay's image of the SLM creeps across the camera
and turns as the mounts warm, and the prism tilts. The bench keeps a clock (hours) that
starts at ``drift.start_h`` when the rig is opened and advances with every spectral
frame (its exposure plus ``frame_overhead_s``); the optics at a time are the described
relay moved by a rate per hour plus a random walk of the offset. The walk is drawn from
the rig's seed on a fixed one-minute grid and the state is held per bench minute, so a
bundle calibrated at 09:00 is off by a known amount at 15:00 (``start_h: 6``).

A capture resumed on a freshly opened rig restarts the clock at ``start_h``: its frames
differ from an uninterrupted run's, unlike every other nuisance.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sassi_bench.optics.relay import SpectralRelay
from sassi_bench.rig.sim.sections import DriftConfig

__all__ = ["DriftModel", "DriftState", "drifted_relay"]

#: Seed stream of the random walk (other nuisances use 11 and 12, the lamps 14).
_SEED_STREAM = 13
_MINUTE_H = 1.0 / 60.0


@dataclass(frozen=True)
class DriftState:
    """How far the optics have moved from their state when calibrated (time zero)."""

    offset_px: tuple[float, float] = (0.0, 0.0)
    rotation_deg: float = 0.0
    tilt_deg: float = 0.0


class DriftModel:
    """The drift of one bench: rates plus a seeded random walk, held per bench minute.

    Examples
    --------
    >>> from sassi_bench.rig.sim.sections import DriftConfig
    >>> model = DriftModel(DriftConfig(relay_offset_px_per_h=(0.04, 0.0)), seed=1)
    >>> model.state_at(6.0).offset_px
    (0.24, 0.0)
    """

    def __init__(self, config: DriftConfig, seed: int) -> None:
        self.config = config
        self._rng = np.random.default_rng(np.random.SeedSequence([seed, _SEED_STREAM]))
        self._walk = np.zeros((1, 2))  # offset random walk at whole minutes, px

    def _walk_at(self, minute: int) -> NDArray[np.float64]:
        if self.config.random_walk_px_per_sqrt_h <= 0:
            return np.zeros(2)
        if minute >= self._walk.shape[0]:
            steps = self._rng.normal(size=(minute + 1 - self._walk.shape[0], 2))
            steps *= self.config.random_walk_px_per_sqrt_h * np.sqrt(_MINUTE_H)
            self._walk = np.vstack([self._walk, self._walk[-1] + np.cumsum(steps, axis=0)])
        return self._walk[minute]

    def state_at(self, hours: float) -> DriftState:
        """The drift at bench time ``hours`` (held per whole minute)."""
        minute = max(int(np.floor(hours * 60.0 + 1e-9)), 0)
        t = minute * _MINUTE_H
        cfg = self.config
        walk = self._walk_at(minute)
        return DriftState(
            offset_px=(
                round(cfg.relay_offset_px_per_h[0] * t + float(walk[0]), 12),
                round(cfg.relay_offset_px_per_h[1] * t + float(walk[1]), 12),
            ),
            rotation_deg=cfg.relay_rotation_deg_per_h * t,
            tilt_deg=cfg.prism_tilt_deg_per_h * t,
        )


def drifted_relay(relay: SpectralRelay, state: DriftState) -> SpectralRelay:
    """The relay moved by a drift: its image offset and rotation changed and its prism
    tilted (incidence angle), the camera left where it was aligned.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> relay = load_rig_description("sim").nominal_relay()
    >>> moved = drifted_relay(relay, DriftState(offset_px=(0.2, 0.0)))
    >>> x0, _ = relay.forward(319.5, 199.5, 550.0)
    >>> x1, _ = moved.forward(319.5, 199.5, 550.0)
    >>> round(float(x1 - x0), 6)
    0.2
    """
    moved = copy.copy(relay)
    moved.optical_centre = (
        relay.optical_centre[0] + state.offset_px[0],
        relay.optical_centre[1] + state.offset_px[1],
    )
    moved.rotation_deg = relay.rotation_deg + state.rotation_deg
    moved.incidence_deg = relay.incidence_deg + state.tilt_deg
    return moved
