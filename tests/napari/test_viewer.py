"""The plugin in napari's headless viewer (``ViewerModel``: the viewer without its Qt window or
OpenGL canvas): open a cube through the npe2 manifest, dock the spectrum (Qt, offscreen), click
a pixel. Skips, saying why, without napari or an offscreen Qt."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

napari = pytest.importorskip("napari", reason="napari is an optional extra (sassi-bench[napari])")


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

        app = QApplication.instance() or QApplication([])
    except Exception as exc:  # no Qt binding, or no offscreen platform plugin
        pytest.skip(f"Qt cannot start offscreen here: {exc}")
    yield ViewerModel()
    app.processEvents()


def test_a_cube_opens_through_the_plugin_and_a_click_plots_its_spectrum(viewer, tmp_path: Path):
    from sassi_bench.napari.widget import spectrum_widget
    from sassi_bench.spectra.cube_io import spectral_cube_dataset, write_netcdf

    wav = np.linspace(420.0, 680.0, 14)
    edges = np.concatenate([[410.0], (wav[:-1] + wav[1:]) / 2, [690.0]])
    cube = np.random.default_rng(1).uniform(0, 1, (6, 9, 14)).astype(np.float32)
    ds = spectral_cube_dataset(
        cube, wav, edges, units="relative photon radiance per bin",
        attrs={"bundle_rig": "sim", "bundle_version": "v0002"},
    )  # fmt: skip
    path = write_netcdf(ds, tmp_path / "scan.nc")

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
