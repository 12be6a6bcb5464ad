"""sassi_bench: calibration and lab-bench workbench for SASSI hyperspectral cameras.

The package is organised in layers (the table in docs/ARCHITECTURE.md, held by
``tests/test_layers.py``): ``optics`` (physics), ``rig`` (devices and the virtual bench),
``acquire`` (patterns, plans, sessions: the code that drives devices), ``bundle`` (the
calibration product and its model contract), ``calibrate`` and ``spectra`` (pure fits and
extraction on arrays), ``snapshot`` (the reference bundle consumer), ``validate`` (scoring),
``workflows`` (procedures end to end) and ``commands`` (the ``sassi-bench`` command line).

``open_rig`` and ``__version__`` are loaded on first use, so importing one layer loads
only what it needs.

Examples
--------
>>> import sassi_bench
>>> rig = sassi_bench.open_rig("sim")
>>> rig.slm.shape
(400, 640)
"""

from __future__ import annotations

import os
from typing import Any

# The virtual bench's compiled kernels run OpenMP parallel loops between Python
# threads' work (the sensor noise) and OpenCV's. OpenMP threads that spin after each
# loop hold the cores that work needs, so they wait passively (set before the runtime
# starts; a value the user set wins). The measurement is in
# docs/notes/2026-11-29-design-render-speed.md (fourth pass).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__all__ = ["__version__", "open_rig"]


def __getattr__(name: str) -> Any:
    if name == "open_rig":
        from sassi_bench.rig import open_rig

        return open_rig
    if name == "__version__":
        from sassi_bench.provenance import package_version

        return package_version()
    raise AttributeError(f"module 'sassi_bench' has no attribute {name!r}")
