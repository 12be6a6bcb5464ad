"""Where a notebook writes its files: under the data root, never into the checkout, and
never over what an earlier run wrote; each says what it wrote or kept."""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

__all__ = ["new_report_folder", "save_cube"]

_RUN = re.compile(r"^run-(\d{3,})$")


def new_report_folder(
    kind: str,
    data: str | os.PathLike[str] | None = None,
    folder: str | os.PathLike[str] | None = None,
) -> Path:
    """A new, empty folder for one run's report: ``<data>/reports/<kind>/run-NNN``.

    Every run of a report cell gets the next number, so running the cell again (after
    moving a slider, or the whole notebook) keeps every earlier report and says so. The
    folder is created here (exclusively: two kernels never share one).

    Parameters
    ----------
    kind
        The report's name (``macbeth``, ``snapshot``).
    data
        Data root (:func:`sassi_bench.paths.data_root`).
    folder
        A folder chosen by the user instead of ``<data>/reports/<kind>``; relative to the
        data root when relative.

    Returns
    -------
    Path

    Examples
    --------
    >>> import tempfile
    >>> root = tempfile.mkdtemp()
    >>> new_report_folder("macbeth", root).name
    report: .../reports/macbeth/run-001 (new)
    'run-001'
    >>> new_report_folder("macbeth", root).name
    report: .../reports/macbeth/run-002 (the earlier report run-001 is kept)
    'run-002'
    """
    from sassi_bench.paths import data_root

    root = data_root(data)
    parent = root / "reports" / kind if folder is None else root / Path(folder)
    parent.mkdir(parents=True, exist_ok=True)
    while True:
        earlier = sorted(
            (int(m.group(1)), p.name)
            for p in parent.iterdir()
            if (m := _RUN.match(p.name)) is not None
        )
        target = parent / f"run-{(earlier[-1][0] if earlier else 0) + 1:03d}"
        try:
            target.mkdir()
        except FileExistsError:
            continue  # another kernel took this number first
        break
    if not earlier:
        kept = "new"
    elif len(earlier) == 1:
        kept = f"the earlier report {earlier[0][1]} is kept"
    else:
        kept = f"the {len(earlier)} earlier reports, {earlier[0][1]} to {earlier[-1][1]}, are kept"
    print(f"report: {_short(target)} ({kept})")
    return target


def _short(path: Path) -> str:
    """``.../reports/macbeth/run-001``: the last parts, so doctests hold on any machine."""
    return ".../" + "/".join(path.parts[-3:])


def save_cube(cube: Any, name: str, data: str | os.PathLike[str] | None = None) -> Path:
    """Write a cube (an :class:`xarray.Dataset`) to ``<data>/cubes/<name>.nc`` unless a
    run before wrote it, and say which.

    ``name`` should name what determines the cube (its scan session and bundle), so a cube
    already there is the same cube and is kept.

    Returns
    -------
    Path

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        save_cube(run.dataset(), "lab-spectral-colorchecker-sim-v0002")
        # cube: wrote .../cubes/lab-spectral-colorchecker-sim-v0002.nc
        # PosixPath('.../cubes/lab-spectral-colorchecker-sim-v0002.nc')
    """
    from sassi_bench.paths import data_root
    from sassi_bench.spectra.cube_io import write_netcdf

    out = data_root(data) / "cubes" / f"{name}.nc"
    if out.exists():
        print(f"cube: kept {out} (written by an earlier run from the same scan and bundle)")
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    write_netcdf(cube, out)
    print(f"cube: wrote {out}")
    return out
