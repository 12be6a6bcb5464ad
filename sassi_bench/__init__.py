"""sassi_bench: calibration and lab-bench workbench for SASSI hyperspectral cameras.

The package is organised in layers (see docs/ARCHITECTURE.md): ``optics`` (physics),
``rig`` (devices and the virtual bench), ``bundle`` (the calibration product and its
model contract), ``acquire`` (patterns, plans, sessions: the code that drives devices),
``calibrate`` and ``spectra`` (pure fits and extraction on arrays), ``workflows``
(procedures end to end) and the ``cli``.

Examples
--------
>>> import sassi_bench
>>> rig = sassi_bench.open_rig("sim")
>>> rig.slm.shape
(400, 640)
"""

from sassi_bench.provenance import package_version
from sassi_bench.rig import open_rig

__version__ = package_version()

__all__ = ["__version__", "open_rig"]
