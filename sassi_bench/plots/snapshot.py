"""Figures of the snapshot validation report; each returns the figure and its data."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "band_psnr_figure",
    "masks_figure",
    "reconstruction_figure",
    "snapshot_figures",
    "snapshot_quick_look",
    "spectra_figure",
    "video_figure",
]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def _display(image: NDArray) -> NDArray[np.float32]:
    """An image scaled to [0, 1] by its 99.5th percentile, gamma 1/2.2."""
    image = np.asarray(image, dtype=np.float32)
    top = float(np.percentile(image, 99.5)) or 1.0
    return np.clip(image / top, 0.0, 1.0) ** (1 / 2.2)


def _band_image(cube: NDArray) -> NDArray[np.float32]:
    """A false-colour view of a cube: the sums of its three thirds of bands as R, G, B."""
    thirds = np.array_split(np.arange(cube.shape[2]), 3)
    return np.stack([cube[..., idx].sum(axis=2) for idx in thirds[::-1]], axis=2)


def masks_figure(result) -> tuple[Any, dict[str, Any]]:
    """Every mask's open pixels (and the adaptive mask's regions) on the guide image.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation`: one panel per entry
        of its ``runs``.

    Returns
    -------
    figure : matplotlib.figure.Figure
        The guide image warped to the SLM with the open pixels and region borders.
    data : dict
        Per run, its number of open pixels and of regions.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = masks_figure(result)
    """
    from skimage.segmentation import find_boundaries

    runs = result.runs
    columns = min(2, len(runs))
    rows_n = -(-len(runs) // columns)
    aspect = runs[next(iter(runs))].mask.shape[0] / runs[next(iter(runs))].mask.shape[1]
    fig = _figure(figsize=(13, 6.5 * aspect * rows_n + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows_n, columns)).ravel()
    for ax in axes[len(runs) :]:
        ax.set_axis_off()
    data: dict[str, Any] = {}
    for ax, (name, run) in zip(axes, runs.items(), strict=False):
        image = _display(run.guide_slm if run.guide_slm.shape[2] == 3 else run.guide_slm[..., 0])
        if image.ndim == 2:
            image = np.repeat(image[..., None], 3, axis=2)
        edges = find_boundaries(run.labels, mode="inner")
        image = image.copy()
        image[edges] = 0.55 * image[edges] + 0.45 * np.array([1.0, 1.0, 0.0])
        ax.imshow(image, interpolation="nearest")
        rows, cols = np.nonzero(run.mask)
        ax.plot(cols, rows, "o", ms=2.5, mfc="#00e5ff", mec="black", mew=0.4)
        ax.set_title(f"{name}: {rows.size} open pixels, {int(run.labels.max()) + 1} regions")
        ax.set_axis_off()
        data[name] = {"open_pixels": int(rows.size), "regions": int(run.labels.max()) + 1}
    fig.suptitle("Masks (cyan) and regions (yellow borders) on the guide image warped to the SLM")
    return fig, data


def snapshot_quick_look(frame, wavelengths_nm: NDArray) -> Any:
    """One reconstructed frame at a glance: the open pixels on the guide image, and the
    rank-1 and guided cubes rendered in sRGB (CIE 1931 colour matching functions).

    Parameters
    ----------
    frame
        A :class:`~sassi_bench.snapshot.pipeline.FrameReconstruction`.
    wavelengths_nm
        (B,) wavelengths of the cubes' bands.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels; both cubes share one brightness scale.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        snapshot_quick_look(frame, bundle.wavelengths).savefig("f000.png")
    """
    from sassi_bench.calibrate.guide_render import render_rgb

    aspect = frame.mask.shape[0] / frame.mask.shape[1]
    fig = _figure(figsize=(16, 5.4 * aspect + 0.9), layout="constrained")
    axes = fig.subplots(1, 3)
    guide = _display(frame.guide_slm)
    axes[0].imshow(guide if guide.ndim == 3 else guide[..., 0], cmap="gray")
    rows, cols = np.nonzero(frame.mask)
    axes[0].plot(cols, rows, "o", ms=2.0, mfc="#00e5ff", mec="black", mew=0.3)
    axes[0].set_title(f"guide on the SLM, {rows.size} open pixels (cyan)")
    # One rendering of both cubes side by side, so they share one brightness scale.
    both = render_rgb(np.concatenate([frame.rank1, frame.guided], axis=1), wavelengths_nm)
    width = frame.rank1.shape[1]
    for ax, title, image in (
        (axes[1], "rank-1", both[:, :width]),
        (axes[2], "guided filter", both[:, width:]),
    ):
        ax.imshow(image)
        ax.set_title(f"{title} (sRGB)")
    for ax in axes:
        ax.set_axis_off()
    return fig


def reconstruction_figure(result) -> tuple[Any, dict[str, Any]]:
    """The scan, both reconstructions of the main snapshot and their error maps.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation`; its first run is shown.

    Returns
    -------
    figure : matplotlib.figure.Figure
        Top: the scan and both reconstructions in false colour; bottom: the detail
        pixels and each method's RMS error over bands relative to the scan's peak.
    data : dict
        The error peak and each method's mean relative RMS error.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = reconstruction_figure(result)
    """
    run = next(iter(result.runs.values()))
    ref = result.reference
    top = float(np.percentile(_band_image(ref)[result.valid], 99.5)) or 1.0
    peak = float(ref[result.valid].max())
    fig = _figure(figsize=(16, 8.4), layout="constrained")
    axes = fig.subplots(2, 3)
    panels = [("scan (reference)", ref), ("rank-1", run.rank1), ("guided filter", run.guided)]
    data: dict[str, Any] = {"error_peak": peak}
    for ax, (title, cube) in zip(axes[0], panels, strict=True):
        ax.imshow(np.clip(_band_image(cube) / top, 0, 1) ** (1 / 2.2))
        ax.set_title(f"{title} (false colour: 3 thirds of the band)")
        ax.set_axis_off()
    axes[1, 0].imshow(result.detail, cmap="gray")
    axes[1, 0].set_title(f"detail pixels ({result.detail.mean():.0%} of the SLM)")
    axes[1, 0].set_axis_off()
    errors = {}
    for title, cube in panels[1:]:
        rms = np.sqrt(np.mean((cube - ref) ** 2, axis=2)) / peak
        rms[~result.valid] = np.nan
        errors[title] = rms
        data[f"{title}_mean_relative_rms"] = float(np.nanmean(rms))
    # One scale for both maps, so their colours compare.
    top_error = max(max(float(np.nanpercentile(rms, 99)) for rms in errors.values()), 1e-6)
    data["error_scale_max"] = top_error
    for ax, (title, rms) in zip(axes[1, 1:], errors.items(), strict=True):
        image = ax.imshow(rms, cmap="magma", vmin=0, vmax=top_error)
        ax.set_title(f"{title}: RMS error over bands / scan peak")
        ax.set_axis_off()
    bar = fig.colorbar(image, ax=list(axes[1, 1:]), shrink=0.8)
    bar.set_label("RMS error / scan peak (one scale for both maps)")
    return fig, data


def band_psnr_figure(result) -> tuple[Any, dict[str, Any]]:
    """Per-band PSNR of every snapshot and method.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation`.

    Returns
    -------
    figure : matplotlib.figure.Figure
        PSNR against wavelength, one line per run and method.
    data : dict
        The wavelengths and, per ``<run>_<method>``, the PSNR of each band.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = band_psnr_figure(result)
    """
    lam = result.wavelengths_nm
    fig = _figure(figsize=(9, 4.2), layout="constrained")
    ax = fig.subplots()
    data: dict[str, Any] = {"wavelength_nm": lam.tolist()}
    styles = {"rank1": "-", "guided": "--"}
    for name, run in result.runs.items():
        for method, s in run.scores.items():
            ax.plot(lam, s.band_psnr_db, styles[method], label=f"{name} {method}")
            data[f"{name}_{method}"] = s.band_psnr_db.tolist()
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("PSNR (dB, scan peak)")
    ax.set_title("Per-band PSNR against the scan")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    return fig, data


def _points(result, count: int) -> list[tuple[int, int]]:
    """Scored pixels spread over the brightness range of the scan, reproducibly."""
    brightness = result.reference.sum(axis=2)
    rows, cols = np.nonzero(result.valid)
    order = np.argsort(brightness[rows, cols])
    picks = order[(np.linspace(0.2, 0.95, count) * (order.size - 1)).astype(int)]
    return [(int(rows[i]), int(cols[i])) for i in picks]


def spectra_figure(result, count: int = 4) -> tuple[Any, dict[str, Any]]:
    """Reconstructed spectra against the scan at a few pixels.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation`; its first run is shown.
    count
        Pixels shown, spread over the brightness range of the scan.

    Returns
    -------
    figure : matplotlib.figure.Figure
        One panel per pixel: the scan, rank-1 and guided spectra.
    data : dict
        The wavelengths and, per pixel, its (u, v) and the three spectra.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = spectra_figure(result, count=3)
    """
    run = next(iter(result.runs.values()))
    lam = result.wavelengths_nm
    points = _points(result, count)
    fig = _figure(figsize=(4.0 * count, 3.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, count, sharey=False))
    data: dict[str, Any] = {"wavelength_nm": lam.tolist(), "points": []}
    for ax, (r, c) in zip(axes, points, strict=True):
        ax.plot(lam, result.reference[r, c], color="black", lw=1.6, label="scan")
        ax.plot(lam, run.rank1[r, c], label="rank-1")
        ax.plot(lam, run.guided[r, c], "--", label="guided")
        ax.set_title(f"u={c}, v={r}")
        ax.set_xlabel("wavelength (nm)")
        data["points"].append(
            {
                "u": c,
                "v": r,
                "scan": result.reference[r, c].tolist(),
                "rank1": run.rank1[r, c].tolist(),
                "guided": run.guided[r, c].tolist(),
            }
        )
    axes[0].set_ylabel(result.units or "signal per bin")
    axes[0].legend(fontsize=8)
    return fig, data


def video_figure(result) -> tuple[Any, dict[str, Any]]:
    """Per-frame PSNR of the video (after the affine fit).

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation` with a ``video``.

    Returns
    -------
    figure : matplotlib.figure.Figure
        PSNR per frame, one line per method.
    data : dict
        The frame numbers and each method's PSNR per frame.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = video_figure(result)
    """
    frames = [f["frame"] for f in result.video]
    fig = _figure(figsize=(7, 3.6), layout="constrained")
    ax = fig.subplots()
    data: dict[str, Any] = {"frame": frames}
    for method in ("rank1", "guided"):
        values = [f[method]["psnr_affine_db"] for f in result.video]
        ax.plot(frames, values, "o-", label=method)
        data[method] = values
    ax.set_xticks(frames)
    ax.set_xlabel("frame (mask from the previous frame's guide image)")
    ax.set_ylabel("PSNR after affine fit (dB)")
    ax.set_title("Video of the moving scene")
    ax.grid(alpha=0.3)
    ax.legend()
    return fig, data


def snapshot_figures(result, points: int = 4) -> dict[str, tuple[Any, dict[str, Any]]]:
    """Every figure of the report, by name.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.snapshot.SnapshotValidation`.
    points
        Pixels of the spectra figure.

    Returns
    -------
    dict
        ``"masks"``, ``"reconstruction"``, ``"band_psnr"``, ``"spectra"`` and, with a
        video, ``"video"`` -> (figure, data).

    Examples
    --------
    Not run here (it needs a procedure's result)::

        figures = snapshot_figures(result)
    """
    figures = {
        "masks": masks_figure(result),
        "reconstruction": reconstruction_figure(result),
        "band_psnr": band_psnr_figure(result),
        "spectra": spectra_figure(result, points),
    }
    if result.video:
        figures["video"] = video_figure(result)
    return figures
