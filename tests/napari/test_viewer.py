"""The plugin in napari's headless viewer (``ViewerModel``: the viewer without its Qt window or
OpenGL canvas): open a cube through the npe2 manifest, dock the spectrum (Qt, offscreen), click
a pixel, draw regions. Skips, saying why, without napari or an offscreen Qt."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

napari = pytest.importorskip(
    "napari", reason="napari is not installed (the napari and dev extras install it)"
)


@pytest.fixture
def viewer(monkeypatch):
    # Offscreen for this test alone: a process-wide setting would send the SLM window
    # tests' Qt to no display.
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    from napari.components import ViewerModel
    from napari.plugins import _initialize_plugins

    _initialize_plugins()  # what napari.Viewer does first: discover the npe2 manifests

    try:
        from qtpy.QtWidgets import QApplication

        existing = QApplication.instance()
        app = existing or QApplication([])
    except Exception as exc:  # no Qt binding, or no offscreen platform plugin
        pytest.skip(f"Qt cannot start offscreen here: {exc}")
    yield ViewerModel()
    app.processEvents()
    if existing is None:  # the offscreen application goes with the test that made it
        _delete_application(app)


def _delete_application(app) -> None:
    """Destroy a Qt application now (the process's next one may use another platform)."""
    import qtpy

    app.closeAllWindows()
    app.processEvents()
    if qtpy.API_NAME.startswith("PySide"):
        import shiboken6

        shiboken6.delete(app)
    else:
        from qtpy import sip

        sip.delete(app)


def _write_cube(tmp_path: Path):
    from sassi_bench.spectra.cube_io import spectral_cube_dataset, write_netcdf

    wav = np.linspace(420.0, 680.0, 14)
    edges = np.concatenate([[410.0], (wav[:-1] + wav[1:]) / 2, [690.0]])
    cube = np.random.default_rng(1).uniform(0, 1, (6, 9, 14)).astype(np.float32)
    ds = spectral_cube_dataset(
        cube, wav, edges, units="relative photon radiance per bin",
        attrs={"bundle_rig": "sim", "bundle_version": "v0002"},
    )  # fmt: skip
    return write_netcdf(ds, tmp_path / "scan.nc"), wav, cube


def test_a_cube_opens_through_the_plugin_and_a_click_plots_its_spectrum(viewer, tmp_path: Path):
    from sassi_bench.napari.widget import spectrum_widget

    path, wav, cube = _write_cube(tmp_path)
    layers = viewer.open(str(path), plugin="sassi-bench")
    assert [layer.name for layer in layers] == ["scan (sRGB)", "scan"]
    rgb, cube_layer = layers
    assert rgb.rgb and cube_layer.data.shape == (14, 6, 9)
    assert cube_layer.metadata["wav"] == pytest.approx(list(wav))

    dock = spectrum_widget(viewer)
    world = cube_layer.data_to_world((3, 4, 7))
    event = type("Click", (), {"position": tuple(world)})()
    for callback in viewer.mouse_drag_callbacks:
        callback(viewer, event)
    shown_wav, values = dock.shown
    np.testing.assert_allclose(shown_wav, wav)
    np.testing.assert_allclose(values, cube[4, 7])
    assert "bundle: sim/v0002" in dock.provenance.text()


def test_a_region_drawn_over_the_cube_plots_its_mean_spectrum_and_spread(viewer, tmp_path):
    from sassi_bench.napari.widget import spectrum_widget

    path, wav, cube = _write_cube(tmp_path)
    viewer.open(str(path), plugin="sassi-bench")
    dock = spectrum_widget(viewer)
    shapes = viewer.add_shapes(name="regions", ndim=2)
    assert dock.shown_regions == {}  # nothing drawn yet

    # Pixel centres sit on integer coordinates: the rectangle holds rows 1-3, columns 2-5,
    # and the thin polygon below it row 4, columns 1-7.
    shapes.add_rectangles([[0.5, 1.5], [3.5, 5.5]])
    shapes.add_polygons([[[3.6, 0.5], [3.6, 7.5], [4.4, 7.5], [4.4, 0.5]]])
    (rectangle, strip) = dock.shown_regions.values()
    np.testing.assert_allclose(rectangle.wavelengths_nm, wav)
    assert rectangle.pixels == 12 and strip.pixels == 7
    np.testing.assert_allclose(rectangle.mean, cube[1:4, 2:6].mean(axis=(0, 1)), rtol=1e-5)
    np.testing.assert_allclose(rectangle.std, cube[1:4, 2:6].std(axis=(0, 1)), rtol=1e-4)
    np.testing.assert_allclose(strip.mean, cube[4, 1:8].mean(axis=0), rtol=1e-5)
    assert "bundle sim/v0002" in dock.axes.get_title() and "regions" in dock.axes.get_title()
    assert dock.axes.get_xlabel() == "wavelength (nm)"
    assert len(dock.axes.collections) == 2  # a standard deviation band per region

    # A labels layer as napari makes it over the cube (with its wavelength axis), painted
    # on one plane: the pixels of each label, whatever plane they were painted on.
    labels = viewer.add_labels(np.zeros((14, 6, 9), np.int32), name="painted")
    painted = labels.data.copy()
    painted[5, 0:2, 0:3] = 1
    painted[2, 5, 8] = 2
    labels.data = painted
    ones, twos = dock.shown_regions.values()
    assert ones.pixels == 6 and twos.pixels == 1
    np.testing.assert_allclose(ones.mean, cube[0:2, 0:3].mean(axis=(0, 1)), rtol=1e-5)
    np.testing.assert_allclose(twos.mean, cube[5, 8], rtol=1e-6)
