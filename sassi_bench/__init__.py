"""sassi_bench: calibration and lab-bench workbench for SASSI hyperspectral cameras.

The package is organised so dependencies point one way (see docs/ARCHITECTURE.md):
``optics`` (physics) <- ``rig`` (devices and the virtual bench) <- ``acquire`` (plans
that drive devices) and ``calibrate`` (pure fits) <- ``bundle`` <- ``spectra`` /
``validate`` <- ``cli``.

Examples
--------
>>> import sassi_bench
>>> rig = sassi_bench.open_rig("sim")
>>> rig.slm.shape
(400, 640)
"""

from importlib.metadata import PackageNotFoundError, version

from sassi_bench.rig import open_rig

try:
    __version__ = version("sassi-bench")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"

__all__ = ["__version__", "open_rig"]
