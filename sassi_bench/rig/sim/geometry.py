"""Where light from an SLM pixel lands on the virtual bench's spectral camera, as built.

The bench is built to its description (:meth:`~sassi_bench.rig.config.RigDescription.nominal_relay`,
the ray trace of :mod:`sassi_bench.optics.relay`): the focal length, the prism's roll and its
incidence angle are solved with the described glass and apex. A bench built otherwise
(``as_built.glass_index_offset``, ``as_built.apex_deg``: another melt, a prism ground to
another angle) then traces its rays through the true prism, with the camera pointed where
the true reference ray goes (a lab aligns its camera on the light), so its streaks differ
in length, shape and position from what the description predicts. A bench not yet
aligned has its prism rolled (``as_built.prism_roll_deg``) or the SLM's image moved on
the camera (``as_built.relay_offset_px``).
"""

from __future__ import annotations

import copy

import numpy as np

from sassi_bench.optics.relay import SpectralRelay
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.sim.as_built import prism_apex_deg, prism_glass
from sassi_bench.rig.sim.sections import as_built_section

__all__ = ["bench_relay"]


def bench_relay(desc: RigDescription) -> SpectralRelay:
    """The virtual bench's SLM -> spectral camera optics: aligned as described, built with
    the true prism.

    Parameters
    ----------
    desc
        A rig description with ``backend: sim``.

    Returns
    -------
    SpectralRelay
        The described relay with the as-built prism in place.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> desc = load_rig_description("sim")
    >>> x, _ = bench_relay(desc).forward(319.5, 199.5, [400.0, 700.0])
    >>> round(float(x[1] - x[0]), 6)  # a bench built as described
    68.0
    """
    relay = desc.nominal_relay().with_prism(prism_glass(desc), prism_apex_deg(desc))
    section = as_built_section(desc)
    if section.prism_roll_deg == 0.0 and section.relay_offset_px == (0.0, 0.0):
        return relay
    # A misaligned bench (``as_built.prism_roll_deg``, ``relay_offset_px``): the prism
    # turned about the optical axis, the SLM's image moved; the camera stays put.
    moved = copy.copy(relay)
    moved.roll_rad = relay.roll_rad + np.deg2rad(section.prism_roll_deg)
    moved.optical_centre = (
        relay.optical_centre[0] + section.relay_offset_px[0],
        relay.optical_centre[1] + section.relay_offset_px[1],
    )
    return moved
