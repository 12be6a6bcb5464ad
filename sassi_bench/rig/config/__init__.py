"""Rig descriptions: YAML files that say what a bench is made of.

A rig YAML is validated against the JSON Schema shipped with the rig package (types,
ranges, no unknown keys), then against physics (the SLM's image and its spectral
streaks must fit on the spectral camera, the lasers must lie on the spectral grid) and
the data sets it names (glass, lamps, guide sensor, QE curve), all when it is loaded.
Errors name the key as a dotted path, with the closest valid name for a typo.

Sections the schema accepts beyond the description describe a virtual bench only, never
the procedures' view of it (how the bench as built differs from its description, and the
real-bench nuisances it renders). They stay raw in :attr:`RigDescription.bench_sections`,
left out of :meth:`RigDescription.to_dict` and the rig's hash, so no session, bundle or
report carries them; :mod:`sassi_bench.rig.sim.sections` parses them, and a guard test
checks that nothing outside ``rig/sim`` reads them.

Keys whose values are the virtual bench's own parts (its guide sensor, its halogen
lamp's temperature, ...) default to those values only on a ``backend: sim`` rig
(:data:`SIM_DEFAULTS`); a real rig that leaves them out gets None, and the workbench
uses the documented fallback.

The package's modules, one job each: :mod:`~sassi_bench.rig.config.description` (the
dataclasses), :mod:`~sassi_bench.rig.config.checks` (the load-time checks) and
:mod:`~sassi_bench.rig.config.loader` (YAML and mappings in, schema, defaults, the
bench-only sections set apart). Import the names from this package.

Examples
--------
>>> desc = load_rig_description("sim")
>>> desc.slm.width, desc.prism.glass
(640, 'N-BK7')
"""

from sassi_bench.rig.config.description import (
    DEFAULT_LASER_TOLERANCE_NM,
    BlurConfig,
    GuideCameraConfig,
    LightConfig,
    PrismConfig,
    RelayConfig,
    RigDescription,
    ScenesConfig,
    SellmeierConfig,
    SlmConfig,
    SpectralCameraConfig,
    SpectralGridConfig,
    rig_dict_sha256,
    rig_relative_path,
)
from sassi_bench.rig.config.loader import (
    SIM_DEFAULTS,
    available_rigs,
    load_rig_description,
    rig_description_from_dict,
)

__all__ = [
    "DEFAULT_LASER_TOLERANCE_NM",
    "SIM_DEFAULTS",
    "BlurConfig",
    "GuideCameraConfig",
    "LightConfig",
    "PrismConfig",
    "RelayConfig",
    "RigDescription",
    "ScenesConfig",
    "SellmeierConfig",
    "SlmConfig",
    "SpectralCameraConfig",
    "SpectralGridConfig",
    "available_rigs",
    "load_rig_description",
    "rig_description_from_dict",
    "rig_dict_sha256",
    "rig_relative_path",
]
