"""Traced grids kept on disk, keyed by what they were traced from.

Tracing a design's grid takes seconds (17 x 11 field nodes x 36 wavelengths x 65 rays);
its result is about 400 kB. The key is the SHA-256 of the design (comments left out),
the grid's nodes, the ray tracer's version and this module's format, so any change traces
again and nothing stale is read. Files are ``.npz`` without pickles, written under a
temporary name and renamed.

The folder is ``$SASSI_BENCH_DESIGN_CACHE``, else ``$XDG_CACHE_HOME/sassi-bench/designs``
(``~/.cache/sassi-bench/designs``).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np

from sassi_bench.optics.design.schema import OpticalDesign
from sassi_bench.optics.design.trace import GRID_ARRAYS, GridSpec, TracedGrid, trace_grid

__all__ = ["cache_folder", "cache_key", "cached_trace"]

# Bumped when what a grid file holds changes.
_FORMAT = 1


def cache_folder() -> Path:
    """Where traced grids are kept (see the module docstring).

    Examples
    --------
    >>> isinstance(cache_folder(), Path)
    True
    """
    given = os.environ.get("SASSI_BENCH_DESIGN_CACHE")
    if given:
        return Path(given).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "sassi-bench" / "designs"


def _tracer_version() -> str:
    try:
        return metadata.version("optiland")
    except metadata.PackageNotFoundError:
        return "absent"


def cache_key(design: OpticalDesign, spec: GridSpec) -> str:
    """SHA-256 naming the traced grid of ``design`` on ``spec``."""
    text = json.dumps(
        {
            "design": design.sha256(),
            "grid": spec.to_mapping(),
            "tracer": _tracer_version(),
            "format": _FORMAT,
        },
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(text.encode()).hexdigest()


def _load(path: Path) -> TracedGrid | None:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: np.array(data[name]) for name in GRID_ARRAYS}
            return TracedGrid(
                u=np.array(data["u"]),
                v=np.array(data["v"]),
                wavelengths_nm=np.array(data["wavelengths_nm"]),
                image_na=float(data["image_na"]),
                seconds=float(data["seconds"]),
                **arrays,
            )
    except (OSError, KeyError, ValueError):
        return None  # unreadable: traced again and replaced


def cached_trace(
    design: OpticalDesign,
    spec: GridSpec,
    progress: Callable[[int, int], None] | None = None,
    folder: Path | None = None,
) -> TracedGrid:
    """The traced grid of ``design`` on ``spec``: from the cache, else traced and stored.

    Parameters
    ----------
    design, spec
        What to trace.
    progress
        Passed to :func:`~sassi_bench.optics.design.trace.trace_grid` when tracing.
    folder
        The cache folder (default :func:`cache_folder`).
    """
    folder = folder if folder is not None else cache_folder()
    key = cache_key(design, spec)
    path = folder / f"{key}.npz"
    if path.is_file():
        grid = _load(path)
        if grid is not None:
            grid.meta["cache"] = str(path)
            return grid
    grid = trace_grid(design, spec, progress=progress)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{key}", suffix=".npz")
        with os.fdopen(fd, "wb") as handle:
            np.savez(
                handle,
                u=grid.u,
                v=grid.v,
                wavelengths_nm=grid.wavelengths_nm,
                image_na=np.float64(grid.image_na),
                seconds=np.float64(grid.seconds),
                **{name: getattr(grid, name) for name in GRID_ARRAYS},
            )
        os.replace(tmp, path)
        grid.meta["cache"] = str(path)
    except OSError:
        pass  # a read-only cache: the grid is still good, traced again next time
    return grid
