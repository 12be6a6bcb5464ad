"""Report figures people read: the same scale where maps are compared, labels that stay
readable at notebook width."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from sassi_bench.calibrate.blur import fit_blur
from sassi_bench.plots.snapshot import reconstruction_figure
from sassi_bench.plots.spectral import blur_figure, residual_maps_figure


def test_the_two_error_maps_of_the_snapshot_report_share_one_colour_scale():
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.5, 1.0, (40, 60, 12))
    run = SimpleNamespace(rank1=ref + 0.2 * rng.normal(size=ref.shape), guided=ref + 0.01)
    result = SimpleNamespace(
        runs={"adaptive": run}, reference=ref, valid=np.ones((40, 60), bool),
        detail=np.zeros((40, 60), bool),
    )  # fmt: skip
    fig, data = reconstruction_figure(result)
    maps = [ax.images[0] for ax in fig.axes[4:6]]
    assert maps[0].get_clim() == maps[1].get_clim() == (0, data["error_scale_max"])
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1  # one colour bar serves both maps
    assert data["guided filter_mean_relative_rms"] < data["rank-1_mean_relative_rms"]


def test_residual_maps_stay_readable_at_notebook_width():
    """Five lasers side by side made a 16-inch figure a notebook shrinks to about 10 inches,
    its labels to unreadable sizes; three maps per row keep the figure about that wide."""
    rng = np.random.default_rng(1)
    u, v = rng.uniform(0, 640, 2000), rng.uniform(0, 400, 2000)
    plane = SimpleNamespace(x=lambda uu, vv: uu * 1.08, y=lambda uu, vv: vv * 1.08)
    lasers = [
        SimpleNamespace(
            laser_map=plane, slm_u=u, slm_v=v, camera_x=u * 1.08 + rng.normal(0, 0.03, u.size),
            camera_y=v * 1.08, wavelength_nm=nm, residual_rms_px=0.03,
        )
        for nm in (450, 520, 532, 635, 670)
    ]  # fmt: skip
    fig = residual_maps_figure(lasers, (400, 640))
    width, _ = fig.get_size_inches()
    assert width <= 11.5
    shown = [ax for ax in fig.axes if ax.get_visible() and ax.get_label() != "<colorbar>"]
    assert len(shown) == 5
    scale = min(1.0, 10.0 / width)  # as a notebook of about 10 inches shows it
    for ax in shown:
        assert ax.title.get_fontsize() * scale >= 9
        assert ax.xaxis.label.get_fontsize() * scale >= 8


def test_the_blur_figure_draws_the_fits_stated_error_as_a_band():
    lam = [450.0, 520.0, 532.0, 635.0, 670.0]
    fit = fit_blur(lam, [1.3, 0.8, 0.78, 1.5, 2.3], aperture_px=1.0)
    ax = blur_figure(fit).axes[0]
    band = ax.collections[0].get_paths()[0].vertices[:, 1]
    sigma = ax.lines[0].get_ydata()
    np.testing.assert_allclose(sigma, fit.camera_width_px(ax.lines[0].get_xdata()))
    error = fit.model.relative_error
    assert error > 0 and f"{100 * error:.1f} % between lasers" in ax.get_title()
    np.testing.assert_allclose(
        [band.min(), band.max()], [sigma.min() * (1 - error), sigma.max() * (1 + error)]
    )
    unstated = fit_blur(lam[:3], [1.3, 0.8, 0.78])  # three lasers: nothing to leave out
    assert not blur_figure(unstated).axes[0].collections


def test_the_scan_band_psnr_leaves_bands_without_light_unscored():
    from sassi_bench.plots.scan import band_psnr_figure

    lam = np.linspace(400.0, 700.0, 31)
    light = np.exp(-0.5 * ((lam - 560.0) / 45.0) ** 2)  # an LED: almost nothing at 400 nm
    psnr = 60.0 + np.where(light < 0.01, 45.0, 0.0)  # noise against the peak: dark bands "best"
    fig, data = band_psnr_figure(lam, {"noise": psnr}, light=light)
    dark = np.asarray(data["dark_bands"])
    assert dark.tolist() == (light < 0.05 * light.max()).tolist() and dark[0] and not dark[16]
    drawn = fig.axes[0].lines[0].get_ydata()
    assert np.isnan(drawn[dark]).all() and np.nanmax(drawn) == 60.0  # the dark 105 dB is gone
    assert all(v is None for v, d in zip(data["noise"], dark, strict=True) if d)
    assert any("not scored" in t.get_text() for t in fig.axes[0].get_legend().get_texts())
