"""Figures of the Macbeth validation report; each returns the figure and its data."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = [
    "band_error_figure",
    "chart_figure",
    "de00_figure",
    "localisation_figure",
    "macbeth_figures",
    "spectra_figure",
    "wavelength_figure",
]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def _shade_unusable(ax, lam, usable) -> None:
    lo, hi = lam[usable][0], lam[usable][-1]
    ax.axvspan(lam[0] - 5, lo, color="0.85", lw=0)
    ax.axvspan(hi, lam[-1] + 5, color="0.85", lw=0)


def spectra_figure(result) -> tuple[Any, dict[str, Any]]:
    """The 24 patch spectra against the reference, in the chart's 4 x 6 layout.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.

    Returns
    -------
    figure : matplotlib.figure.Figure
        One panel per patch: the measured mean, ± 1 std and the reference.
    data : dict
        The plotted values: wavelengths, usable bins, patch names, measured, spread,
        reference and pixel counts.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = spectra_figure(result)
        len(data["measured"])
        # 24
    """
    lam, usable = result.wavelengths_nm, result.usable
    fig = _figure(figsize=(13.5, 8.2), layout="constrained")
    axes = fig.subplots(4, 6, sharex=True, sharey=True)
    top = float(np.nanmax(np.r_[result.reference.ravel(), result.reflectance[:, usable].ravel()]))
    for k, ax in enumerate(axes.ravel()):
        _shade_unusable(ax, lam, usable)
        colour = np.clip(result.srgb_reference[k], 0, 1)
        ax.plot(lam, result.reference[k], color="black", lw=1.2, label="reference")
        mean, spread = result.reflectance[k], result.spread[k]
        ax.fill_between(lam, mean - spread, mean + spread, color=colour, alpha=0.35, lw=0)
        ax.plot(lam, mean, color=colour, lw=1.6, label="measured")
        ax.plot(lam, mean, color="black", lw=0.4, alpha=0.6)
        ax.set_title(
            f"{k + 1} {result.patch_names[k]}\ndE00 {result.de00[k]:.2f}, "
            f"{result.angle_deg[k]:.2f}°",
            fontsize=8,
        )
        ax.set_ylim(0, 1.1 * top)
        ax.set_xlim(lam[0], lam[-1])
        ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("nm", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("reflectance", fontsize=8)
    axes[0, 0].legend(fontsize=7, loc="upper left")
    fig.suptitle(
        "Patch reflectance: measured mean ± 1 std (colour) vs reference (black); "
        "grey: outside the usable band",
        fontsize=10,
    )
    data = {
        "wavelength_nm": lam.tolist(),
        "usable": result.usable.tolist(),
        "patch_names": list(result.patch_names),
        "measured": np.nan_to_num(result.reflectance).tolist(),
        "spread": np.nan_to_num(result.spread).tolist(),
        "reference": result.reference.tolist(),
        "pixels": result.pixels.tolist(),
    }
    return fig, data


def de00_figure(result, tolerances) -> tuple[Any, dict[str, Any]]:
    """CIEDE2000 per patch with the tolerances.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.
    tolerances
        The procedure's tolerances: ``max_de00`` and ``mean_de00``.

    Returns
    -------
    figure : matplotlib.figure.Figure
        One bar per patch, in the patch's reference colour, and the tolerance lines.
    data : dict
        Patch numbers, CIEDE2000 per patch and the two tolerances.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = de00_figure(result, {"max_de00": 6.0, "mean_de00": 3.0})
    """
    fig = _figure(figsize=(10, 3.6), layout="constrained")
    ax = fig.subplots()
    x = np.arange(1, 25)
    ax.bar(x, result.de00, color=np.clip(result.srgb_reference, 0, 1), edgecolor="black", lw=0.6)
    ax.axhline(tolerances["max_de00"], color="crimson", ls="--", lw=1, label="max tolerance")
    ax.axhline(tolerances["mean_de00"], color="darkorange", ls=":", lw=1, label="mean tolerance")
    ax.axhline(float(np.mean(result.de00)), color="black", lw=1, label="measured mean")
    ax.set_xticks(x)
    ax.set_xlabel("patch")
    ax.set_ylabel("CIEDE2000")
    ax.set_ylim(0, 1.15 * max(float(np.max(result.de00)), tolerances["max_de00"]))
    ax.set_title("Colour difference per patch (D65, CIE 1931 2°)", fontsize=10)
    ax.legend(fontsize=8, ncols=3, loc="upper left")
    data = {
        "patch": x.tolist(),
        "de00": result.de00.tolist(),
        "mean_tolerance": tolerances["mean_de00"],
        "max_tolerance": tolerances["max_de00"],
    }
    return fig, data


def _swatches(rgb) -> np.ndarray:
    """A 4 x 6 chart image with dark gaps, 20 px per patch."""
    image = np.full((4 * 24 + 4, 6 * 24 + 4, 3), 0.1)
    for k, colour in enumerate(np.clip(rgb, 0, 1)):
        r, c = divmod(k, 6)
        image[4 + 24 * r : 24 * (r + 1), 4 + 24 * c : 24 * (c + 1)] = colour
    return image


def chart_figure(result) -> tuple[Any, dict[str, Any]]:
    """The measured chart rendered beside the reference swatches (D65, sRGB).

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.

    Returns
    -------
    figure : matplotlib.figure.Figure
        The measured and the reference chart as swatches.
    data : dict
        sRGB and CIELAB of the measured and the reference patches.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = chart_figure(result)
    """
    fig = _figure(figsize=(10, 3.4), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, rgb, title in (
        (axes[0], result.srgb_measured, "measured (rendered under D65)"),
        (axes[1], result.srgb_reference, "reference"),
    ):
        ax.imshow(_swatches(rgb), interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_axis_off()
    data = {
        "srgb_measured": result.srgb_measured.tolist(),
        "srgb_reference": result.srgb_reference.tolist(),
        "lab_measured": result.lab_measured.tolist(),
        "lab_reference": result.lab_reference.tolist(),
    }
    return fig, data


def _located(grid) -> str:
    """How the 24 measured patches were placed, e.g. "24 patches, lattice fitted to 23 found"."""
    if grid.method == "corners":
        return "24 patches from 4 clicked centres"
    if grid.detected >= 24:
        return "24 patches, all found by the detector"
    return f"24 patches, lattice fitted to the {grid.detected} the detector found"


def grid_figure(picture, origin: tuple[int, int], grid, interior: float):
    """A picture of the chart with a patch grid's interiors drawn on it.

    Parameters
    ----------
    picture
        (H, W, 3) RGB picture, or None for the grid alone.
    origin
        SLM (row, col) of the picture's first pixel.
    grid
        A :class:`~sassi_bench.validate.locate.ChartGrid`.
    interior
        Side of each measured square, as a fraction of the patch pitch.

    Returns
    -------
    matplotlib.figure.Figure
        The picture (if any) with each patch's measured square and number, in SLM pixels.

    Examples
    --------
    >>> from sassi_bench.validate.locate import grid_from_corners
    >>> grid = grid_from_corners([[10, 20], [60, 20], [60, 50], [10, 50]])
    >>> len(grid_figure(None, (0, 0), grid, 0.5).axes)
    1
    """
    fig = _figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.subplots()
    r0, c0 = origin
    if picture is not None:
        h, w = picture.shape[:2]
        ax.imshow(picture, extent=(c0 - 0.5, c0 + w - 0.5, r0 + h - 0.5, r0 - 0.5))
    centres = grid.centres()
    half = interior / 2.0
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half], [-half, -half]])
    rows, cols = np.divmod(np.arange(24), 6)
    for k in range(24):
        corners = grid.to_slm(square + np.array([cols[k], rows[k]]))
        ax.plot(corners[:, 0], corners[:, 1], color="white" if picture is not None else "k", lw=1)
        ax.text(*centres[k], str(k + 1), color="white", ha="center", va="center", fontsize=7)
    ax.set_xlabel("SLM u (px)")
    ax.set_ylabel("SLM v (px)")
    if picture is None:
        ax.invert_yaxis()
    ax.set_title(f"Patch localisation: {_located(grid)}", fontsize=10)
    return fig


def localisation_figure(result, interior: float) -> tuple[Any, dict[str, Any]]:
    """The picture the chart was found on, with the measured patch interiors.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.
    interior
        Side of each measured square, as a fraction of the patch pitch.

    Returns
    -------
    figure : matplotlib.figure.Figure
        See :func:`grid_figure`.
    data : dict
        How the chart was located, its homography to the SLM and the patch centres.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = localisation_figure(result, 0.5)
    """
    fig = grid_figure(result.picture, result.picture_origin, result.grid, interior)
    centres = result.grid.centres()
    data = {
        "method": result.grid.method,
        "detected": result.grid.detected,
        "homography_chart_to_slm": result.grid.homography.tolist(),
        "centres_uv": centres.tolist(),
        "interior": interior,
    }
    return fig, data


def wavelength_figure(result, bundle) -> tuple[Any, dict[str, Any]]:
    """The bundle's wavelength bins: width per bin, and the white signal that set the band.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.
    bundle
        The :class:`~sassi_bench.bundle.CalibrationBundle` validated (its bin resolutions).

    Returns
    -------
    figure : matplotlib.figure.Figure
        Bin width against bin centre, and the relative white signal with the usable band.
    data : dict
        Bin centres, edges and resolutions, the white signal and the usable band.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = wavelength_figure(result, bundle)
    """
    lam, edges = result.wavelengths_nm, result.bin_edges_nm
    fig = _figure(figsize=(10, 3.4), layout="constrained")
    axes = fig.subplots(1, 2)
    axes[0].plot(lam, np.diff(edges), ".-")
    axes[0].set_xlabel("bin centre (nm)")
    axes[0].set_ylabel("bin width (nm)")
    axes[0].set_title(f"{lam.size} wavelength bins, {edges[0]:.1f}-{edges[-1]:.1f} nm", fontsize=10)
    _shade_unusable(axes[1], lam, result.usable)
    axes[1].plot(lam, result.white_relative, ".-")
    axes[1].set_xlabel("bin centre (nm)")
    axes[1].set_ylabel("white signal / peak")
    lo, hi = result.band_nm
    axes[1].set_title(f"Usable band {lo:.0f}-{hi:.0f} nm (unshaded)", fontsize=10)
    data = {
        "bin_centres_nm": lam.tolist(),
        "bin_edges_nm": edges.tolist(),
        "bin_resolution_nm": np.asarray(bundle.bin_resolution_nm).tolist(),
        "white_relative": result.white_relative.tolist(),
        "usable_band_nm": [lo, hi],
    }
    return fig, data


def band_error_figure(result, errors) -> tuple[Any, dict[str, Any]]:
    """Per-band error of patches against the reference, with the band-edge zones marked.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.
    errors
        :class:`~sassi_bench.validate.band_error.PatchBandError` of each patch to draw.

    Returns
    -------
    figure : matplotlib.figure.Figure
        One panel per patch: measured minus reference per band, +- 2 standard errors
        shaded, the edge zones and the steep-reference bins marked.
    data : dict
        The wavelengths and each patch's error, standard error, zones and shares.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig, data = band_error_figure(result, [patch_band_error(result, 8, True)])
    """
    lam = result.wavelengths_nm
    fig = _figure(figsize=(9, 2.6 * max(len(errors), 1) + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(max(len(errors), 1), 1, sharex=True))
    data: dict[str, Any] = {"wavelength_nm": lam.tolist(), "patches": []}
    for ax, e in zip(axes, errors, strict=False):
        _shade_unusable(ax, lam, result.usable)
        zones = np.asarray(e.zones)
        for zone, colour in (("edge", "tab:orange"), ("steep", "tab:purple")):
            for k in np.flatnonzero(zones == zone):
                lo = lam[k] - 0.5 * (lam[min(k + 1, lam.size - 1)] - lam[max(k - 1, 0)]) / 2
                hi = lam[k] + 0.5 * (lam[min(k + 1, lam.size - 1)] - lam[max(k - 1, 0)]) / 2
                ax.axvspan(lo, hi, color=colour, alpha=0.12, lw=0)
        ax.fill_between(lam, -2 * e.standard_error, 2 * e.standard_error, color="0.6",
                        alpha=0.5, lw=0, label="+-2 standard errors (noise)")  # fmt: skip
        ax.axhline(0.0, color="black", lw=0.6)
        ax.plot(lam, e.error, ".-", color="tab:red", label="measured - reference")
        shares = ", ".join(f"{100 * v:.0f} % {k}" for k, v in e.shares.items())
        ax.set_title(
            f"Patch {e.patch + 1} {e.name} ({e.state}): its error per band; {shares}",
            fontsize=9,
        )
        ax.set_ylabel("reflectance error")
        ax.margins(y=0.15)  # the band's last point, often the largest, clear of the frame
        ax.grid(alpha=0.3)
        data["patches"].append(e.to_dict())
    axes[0].plot([], [], color="tab:orange", alpha=0.4, lw=6, label="band-edge zone")
    axes[0].plot([], [], color="tab:purple", alpha=0.4, lw=6, label="steep reference")
    axes[0].legend(fontsize=7, ncol=2)
    axes[-1].set_xlabel("wavelength (nm)")
    return fig, data


def macbeth_figures(
    result, bundle, procedure, band_errors=()
) -> dict[str, tuple[Any, dict[str, Any]]]:
    """Every figure of the report with its data, by name.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.validate.macbeth.MacbethResult`.
    bundle
        The :class:`~sassi_bench.bundle.CalibrationBundle` validated.
    procedure
        The validation procedure: its ``tolerances`` and ``localisation.interior``.
    band_errors
        :class:`~sassi_bench.validate.band_error.PatchBandError` of the patches whose
        per-band error is drawn (the failing ones).

    Returns
    -------
    dict
        ``"band_error"``, ``"spectra"``, ``"de00"``, ``"chart"``, ``"localisation"`` and
        ``"wavelength_calibration"`` -> (figure, data).

    Examples
    --------
    Not run here (it needs a procedure's result)::

        figures = macbeth_figures(result, bundle, procedure)
        fig, data = figures["de00"]
    """
    return {
        "band_error": band_error_figure(result, band_errors),
        "spectra": spectra_figure(result),
        "de00": de00_figure(result, procedure["tolerances"]),
        "chart": chart_figure(result),
        "localisation": localisation_figure(result, float(procedure["localisation"]["interior"])),
        "wavelength_calibration": wavelength_figure(result, bundle),
    }
