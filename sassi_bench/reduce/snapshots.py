"""SASSI snapshot sessions into cubes: the masks' planning, reconstruction, outputs.

:func:`adaptive_planner` draws the next frame's adaptive mask from a guide image under
the procedure's spacing rule (:func:`procedure_spacing`), as the capture
(:func:`~sassi_bench.workflows.snapshot.take_snapshots`) asks for it.
:func:`reconstruct_snapshots` turns snapshot sessions (just taken, or taken long ago and
re-read from disk) into cubes on the SLM grid at the bundle's bins, rank-1 and guided,
and :func:`write_frame` writes them like scan cubes (NetCDF, ENVI) beside a quick-look
PNG. ``sassi-bench snapshot reconstruct`` runs them.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.snapshots import SnapshotVideo
from sassi_bench.bundle import CalibrationBundle, MaskSpacing
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.plots.snapshot import snapshot_quick_look
from sassi_bench.snapshot import (
    FrameReconstruction,
    adaptive_samples,
    guide_on_slm,
    planned_mask,
    reconstruct_frame,
    snapshot_dataset,
    write_cube,
)
from sassi_bench.spectra.cube_io import write_envi
from sassi_bench.spectra.deblur import SpectralDeblur

__all__ = [
    "METHODS",
    "adaptive_planner",
    "check_outputs_free",
    "frame_outputs",
    "frame_samples",
    "procedure_spacing",
    "reconstruct_snapshots",
    "write_frame",
]

#: The reconstructions written, by file suffix.
METHODS = {"rank1": "rank-1 per region", "guided": "masked guided filter"}


def procedure_spacing(bundle: CalibrationBundle, procedure: Mapping[str, Any]) -> MaskSpacing:
    """The bundle's spacing rule at the procedure's row pitch (``snapshot.row_pitch_px``).

    Parameters
    ----------
    bundle
        The calibration bundle (its dispersion and blur set the rule).
    procedure
        A snapshot procedure; without a row pitch the bundle's own is used.

    Returns
    -------
    MaskSpacing
        Which SLM pixels may be open together.

    Examples
    --------
    >>> from sassi_bench.procedure import load_procedure
    >>> spacing = procedure_spacing(bundle, load_procedure("snapshot_validation"))
    """
    return bundle.mask_spacing(row_pitch=procedure["snapshot"].get("row_pitch_px"))


def adaptive_planner(
    bundle: CalibrationBundle, spacing: MaskSpacing, compactness: float
) -> Callable[[NDArray[Any]], NDArray[np.bool_]]:
    """The next frame's mask as a function of a raw guide image: its planned adaptive mask
    on the SLM grid (:func:`~sassi_bench.snapshot.adaptive.planned_mask`; what
    :func:`~sassi_bench.acquire.snapshots.capture_snapshots` calls).

    Parameters
    ----------
    bundle
        The bundle whose guide homography warps the guide image onto the SLM.
    spacing
        The spacing rule every mask keeps.
    compactness
        SLIC compactness of the superpixels.

    Returns
    -------
    callable
        Raw guide image -> (H, W) bool mask on the SLM.

    Examples
    --------
    Not run here (it needs captured sessions)::

        next_mask = adaptive_planner(bundle, spacing, 10.0)
    """

    def next_mask(guide: NDArray[Any]) -> NDArray[np.bool_]:
        return planned_mask(guide_on_slm(bundle, guide), spacing, compactness=compactness).mask

    return next_mask


def frame_samples(
    video: SnapshotVideo,
    t: int,
    bundle: CalibrationBundle,
    spacing: MaskSpacing,
    compactness: float,
) -> NDArray[np.int32] | None:
    """Region centres of frame ``t``: the adaptive samples of the guide image its mask was
    planned on (the previous frame's, or the preview's), else None (every open pixel).

    Parameters
    ----------
    video
        The snapshot sessions.
    t
        Frame number.
    bundle
        The bundle the masks were drawn with.
    spacing
        The spacing rule of the masks.
    compactness
        SLIC compactness the masks were drawn with.

    Returns
    -------
    ndarray or None
        (N, 2) int32 (row, column) samples, or None when the frame's mask was not adaptive.

    Examples
    --------
    Not run here (it needs captured sessions)::

        samples = frame_samples(video, 0, bundle, spacing, 10.0)
    """
    if video.frames[t].plan.parameters.get("mask_kind") != "adaptive":
        return None
    planned_on = guide_on_slm(bundle, video.guide(t - 1 if t > 0 else -1))
    return adaptive_samples(video.mask(t), planned_on, spacing, compactness=compactness)


def reconstruct_snapshots(
    video: SnapshotVideo,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    frames: Sequence[int] | None = None,
    progress: bool = True,
) -> Iterator[FrameReconstruction]:
    """Reconstruct frames of a snapshot video (default: all), one at a time (cubes are
    large).

    Parameters
    ----------
    video
        The snapshot sessions (:func:`take_snapshots` or
        :func:`~sassi_bench.acquire.snapshot_ids.open_snapshots`); a frame that took the
        closed SLM has its leak subtracted pixel by pixel.
    bundle
        The bundle to reconstruct with.
    procedure
        A snapshot procedure: its ``snapshot`` (row pitch, compactness) and
        ``reconstruction`` (guided filter radius and eps) sections.
    frames
        Indices of the frames to reconstruct (default: every frame of ``video``).
    progress
        Show a progress bar over the frames.

    Yields
    ------
    FrameReconstruction
        Each frame's mask, guide on the SLM, and rank-1 and guided cubes.

    Examples
    --------
    Not run here (it needs captured sessions)::

        for frame in reconstruct_snapshots(video, bundle, procedure):
            frame.rank1.shape
    """
    from tqdm.auto import tqdm

    spacing = procedure_spacing(bundle, procedure)
    compactness = float(procedure["snapshot"]["compactness"])
    recon = procedure["reconstruction"]
    deblur = SpectralDeblur.from_bundle(bundle)
    chosen = range(len(video.frames)) if frames is None else frames
    for t in tqdm(chosen, desc="reconstruct", disable=not progress):
        yield reconstruct_frame(
            bundle, video.guide(t), video.spectral(t), video.mask(t),
            exposure_s=video.exposures.spectral_s,
            samples=frame_samples(video, t, bundle, spacing, compactness),
            compactness=compactness, guided_radius=recon["guided_radius_px"],
            guided_eps=recon["guided_eps"], deblur=deblur, closed=video.closed(t),
        )  # fmt: skip


def frame_outputs(out: str | os.PathLike[str], name: str) -> list[Path]:
    """The files :func:`write_frame` writes for frame ``name`` (ENVI aside).

    Parameters
    ----------
    out
        The output folder.
    name
        The frame's name, e.g. ``"snap-f000"``.

    Returns
    -------
    list of pathlib.Path
        One NetCDF cube per method of :data:`METHODS`, then the quick-look PNG.

    Examples
    --------
    >>> [p.name for p in frame_outputs("snaps", "snap-f000")]
    ['snap-f000-rank1.nc', 'snap-f000-guided.nc', 'snap-f000.png']
    """
    folder = Path(out)
    return [folder / f"{name}-{m}.nc" for m in METHODS] + [folder / f"{name}.png"]


def _ours(path: Path, name: str, bundle: CalibrationBundle | None) -> bool:
    """Whether an existing output of frame ``name`` was written from that frame's session
    with ``bundle`` (an interrupted run's, which its resumption keeps): a cube says so in
    its attributes; a quick look or ENVI file belongs with its frame's rank-1 cube."""
    import xarray as xr

    if bundle is None:
        return False
    cube = path if path.suffix == ".nc" else path.parent / f"{name}-rank1.nc"
    try:
        with xr.open_dataset(cube) as ds:
            attrs = dict(ds.attrs)
    except (OSError, ValueError):
        return False
    wanted = {"session": name, "bundle_rig": bundle.rig_name, "bundle_version": bundle.version}
    return all(attrs.get(key) == value for key, value in wanted.items())


def check_outputs_free(
    out: str | os.PathLike[str], names: list[str], bundle: CalibrationBundle | None = None
) -> None:
    """Refuse to write frames whose cubes already exist in ``out`` (checked before any
    capture, so nothing is captured for nothing and nothing is overwritten). With
    ``bundle``, files an interrupted run wrote for the same frames with that bundle are
    not in the way: resuming keeps them and writes the rest.

    Parameters
    ----------
    out
        The output folder.
    names
        The frames to be written.

    Raises
    ------
    ProcedureError
        Naming (up to three of) the files that exist.

    Examples
    --------
    >>> check_outputs_free("a-new-folder", ["snap-f000"])
    """
    taken = [
        str(p)
        for name in names
        for p in frame_outputs(out, name)
        if p.exists() and not _ours(p, name, bundle)
    ]
    if taken:
        raise ProcedureError(
            step_error(
                "snapshot cubes",
                f"{', '.join(taken[:3])}{' and more' if len(taken) > 3 else ''} already exist",
                "write into another --out folder, or move the old cubes away",
            )
        )


def write_frame(
    frame: FrameReconstruction,
    bundle: CalibrationBundle,
    out: str | os.PathLike[str],
    name: str,
    *,
    session: str,
    envi: bool = True,
    exposure_s: float | None = None,
) -> list[Path]:
    """Write a frame's cubes (``<name>-rank1.nc``, ``<name>-guided.nc``, and ENVI) and a
    quick-look PNG (``<name>.png``) into ``out``, each file atomically; never over an
    existing file. Files an interrupted run already wrote for this frame's session with
    this bundle are kept (and returned), so a resumed run completes the frame. The cubes
    carry the bundle's response they were divided by and, given, the spectral exposure.

    Parameters
    ----------
    frame
        A reconstructed frame.
    bundle
        The bundle it was reconstructed with (its bins and provenance).
    out
        The output folder; created if needed.
    name
        The files' stem, e.g. ``"snap-f000"``.
    session
        The frame's session id, recorded in the cubes.
    envi
        Also write each cube as ENVI (``.hdr``/``.img``).
    exposure_s
        The spectral exposure the radiance was divided by (seconds), stored in the cubes.

    Returns
    -------
    list of pathlib.Path
        Every file written.

    Raises
    ------
    ProcedureError
        If one of the frame's files exists already.

    Examples
    --------
    Not run here (it needs captured sessions)::

        write_frame(frame, bundle, "snapshots", "snap-f000", session="snap-f000")
    """
    from sassi_bench._shared.atomic import atomic_write_bytes
    from sassi_bench.plots.png import figure_png

    kept = bundle if session == name else None
    check_outputs_free(out, [name], kept)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for method, title in METHODS.items():
        cube = folder / f"{name}-{method}.nc"
        header = None if not envi else folder / f"{name}-{method}.hdr"
        # What exists is ours (checked above): an interrupted run wrote it whole.
        missing = [p for p in (cube, header) if p is not None and not p.exists()]
        if missing:
            ds = snapshot_dataset(
                getattr(frame, method), bundle, units=frame.units, method=title,
                exposure_s=exposure_s,
                attrs={"session": session, "open_pixels": int(frame.mask.sum())},
            )  # fmt: skip
            if cube in missing:
                write_cube(ds, cube)
            if header in missing:
                write_envi(ds, header)
        written += [p for p in (cube, header) if p is not None]
    quick_look = folder / f"{name}.png"
    if not quick_look.exists():
        figure = snapshot_quick_look(frame, bundle.wavelengths)
        atomic_write_bytes(quick_look, figure_png(figure, dpi=100), overwrite=False)
    written.append(quick_look)
    return written
