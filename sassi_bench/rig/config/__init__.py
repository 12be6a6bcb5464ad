"""Rig descriptions: YAML files that say what a bench is made of.

A rig YAML is validated against the JSON Schema shipped with the rig package (types,
ranges, no unknown keys), then against physics (the SLM's image and its spectral
streaks must fit on the spectral camera, the lasers must lie on the spectral grid) and
the data sets it names (glass, lamps, guide sensor, QE curve), all when it is loaded.
Errors name the key as a dotted path, with the closest valid name for a typo.

Two sections describe the virtual bench only, never the procedures' view of it:
``as_built`` (how the bench as built differs from this description: lasers off their
label, another glass melt, the lamp's true temperature, ...) and ``nuisance`` (laser
power jitter, hot pixels, SLM crosstalk, stray light, speckle). They are parsed into
:class:`AsBuiltConfig` and :class:`NuisanceConfig` on the description for the virtual
bench, and left out of :meth:`RigDescription.to_dict` and the rig's hash, so no session,
bundle or report carries them; a guard test checks that nothing outside ``rig/sim``
and this package reads them.

Keys whose values are the virtual bench's own parts (its guide sensor, its halogen
lamp's temperature, ...) default to those values only on a ``backend: sim`` rig
(:data:`SIM_DEFAULTS`); a real rig that leaves them out gets None, and the workbench
uses the documented fallback.

The package's modules, one job each: :mod:`~sassi_bench.rig.config.description` (the
dataclasses), :mod:`~sassi_bench.rig.config.checks` (the load-time checks) and
:mod:`~sassi_bench.rig.config.loader` (YAML and mappings in, schema, defaults, the
bench-only sections parsed). Import the names from this package.

Examples
--------
>>> desc = load_rig_description("sim")
>>> desc.slm.width, desc.prism.glass
(640, 'N-BK7')
"""

from sassi_bench.rig.config.description import (
    AsBuiltConfig,
    BlurConfig,
    GuideCameraConfig,
    LightConfig,
    NuisanceConfig,
    PrismConfig,
    RelayConfig,
    RigDescription,
    ScenesConfig,
    SellmeierConfig,
    SlmConfig,
    SpectralCameraConfig,
    SpectralGridConfig,
    as_built_path,
    light_names,
)
from sassi_bench.rig.config.loader import (
    SIM_DEFAULTS,
    available_rigs,
    load_rig_description,
    rig_description_from_dict,
)

__all__ = [
    "SIM_DEFAULTS",
    "AsBuiltConfig",
    "BlurConfig",
    "GuideCameraConfig",
    "LightConfig",
    "NuisanceConfig",
    "PrismConfig",
    "RelayConfig",
    "RigDescription",
    "ScenesConfig",
    "SellmeierConfig",
    "SlmConfig",
    "SpectralCameraConfig",
    "SpectralGridConfig",
    "as_built_path",
    "available_rigs",
    "light_names",
    "load_rig_description",
    "rig_description_from_dict",
]
