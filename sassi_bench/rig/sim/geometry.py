"""Where light from an SLM pixel lands on the virtual bench's spectral camera, as built.

The bench is built to its description (:meth:`~sassi_bench.rig.config.RigDescription.nominal_relay`,
the ray trace of :mod:`sassi_bench.optics.relay`): the focal length, the prism's roll and its
incidence angle are solved with the described glass and apex. A bench built otherwise
(``as_built.glass_index_offset``, ``as_built.apex_deg``: another melt, a prism ground to
another angle) then traces its rays through the true prism, with the camera pointed where
the true reference ray goes (a lab aligns its camera on the light), so its streaks differ
in length, shape and position from what the description predicts. The relay's SLM side
can be built otherwise too (``as_built.relay_scale``, ``relay_rotation_deg``,
``relay_offset_px``, ``relay_distortion_k1``:
:meth:`~sassi_bench.optics.relay.SpectralRelay.with_relay`). A design rig's bench is its
design with the surfaces ``as_built.design`` changes (a decentred lens, a defocused
camera, a rolled prism), traced like the description.
A bench not yet aligned has its prism rolled (``as_built.prism_roll_deg``).
"""

from __future__ import annotations

import copy

import numpy as np

from sassi_bench.optics.design import DesignRelay, design_relay, with_override
from sassi_bench.optics.relay import SpectralRelay
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.sim.as_built import prism_apex_deg, prism_glass
from sassi_bench.rig.sim.sections import as_built_section

__all__ = ["bench_relay"]


def bench_relay(desc: RigDescription) -> SpectralRelay | DesignRelay:
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
    if desc.design is not None:
        return bench_design_relay(desc)
    true = as_built_section(desc)
    relay = desc.nominal_relay().with_relay(
        scale=true.relay_scale,
        rotation_deg=true.relay_rotation_deg,
        offset_px=true.relay_offset_px,
        distortion_k1=true.relay_distortion_k1,
    )
    relay = relay.with_prism(prism_glass(desc), prism_apex_deg(desc))
    if true.prism_roll_deg == 0.0:
        return relay
    # A bench not yet aligned: the prism turned about the optical axis; the camera stays put.
    rolled = copy.copy(relay)
    rolled.roll_rad = relay.roll_rad + np.deg2rad(true.prism_roll_deg)
    return rolled


def bench_design_relay(desc: RigDescription) -> DesignRelay:
    """A design rig's optics as built: the described design with the surfaces
    ``as_built.design`` changes, traced (once, then from the cache).

    Parameters
    ----------
    desc
        A ``backend: sim`` rig description with a ``design:`` section.
    """
    assert desc.design is not None
    design = desc.design
    override = as_built_section(desc).design
    if override:
        design = with_override(design, override, "as_built.design")
    return design_relay(
        design,
        (desc.slm.height, desc.slm.width),
        (desc.spectral_camera.height, desc.spectral_camera.width),
        (desc.spectral_grid.start_nm, desc.spectral_grid.stop_nm),
    )
