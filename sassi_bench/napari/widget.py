"""The spectrum dock: the clicked pixel's spectrum in nm, the mean spectrum (with its standard
deviation band) of each region drawn on a Shapes or Labels layer over the cube, and the
bundle and inputs the cube came from.

Qt is imported when the dock is made (napari brings it), so this module imports without it.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from sassi_bench.napari.spectrum import (
    RegionSpectrum,
    bundle_name,
    pixel_spectrum,
    provenance_text,
    region_spectrum,
)

__all__ = ["region_masks", "spectrum_widget"]

#: Regions drawn at most (the first ones of a layer); more would not read on one plot.
MAX_REGIONS = 10


def spectrum_widget(napari_viewer: Any) -> Any:
    """A dock that plots the spectrum of the pixel clicked in the viewer, or the mean spectrum
    of each region drawn on a Shapes or Labels layer (of the selected cube layer, else the
    first cube layer), and shows the cube's bundle and inputs.

    Examples
    --------
    Not run here (it needs napari and Qt)::

        viewer.window.add_dock_widget(spectrum_widget(viewer))
        viewer.add_shapes([[10, 10], [10, 60], [40, 60], [40, 10]])  # its mean spectrum
    """
    return _widget_class()(napari_viewer)


def _is_cube(layer: Any) -> bool:
    return "wav" in layer.metadata and not getattr(layer, "rgb", False)


def _is_region_layer(layer: Any) -> bool:
    return type(layer).__name__ in ("Shapes", "Labels")


def region_masks(layer: Any, yx_shape: tuple[int, int]) -> list[tuple[str, np.ndarray]]:
    """The regions of a Shapes layer (one a shape) or a Labels layer (one a label) as
    boolean ``(y, x)`` masks of ``yx_shape``, named, in their order.

    A Labels layer with more dimensions than y and x (napari's new labels layer takes the
    cube's wavelength axis) counts a pixel painted on any plane.

    Examples
    --------
    Not run here (it needs napari)::

        region_masks(viewer.layers["Shapes"], (400, 640))
        # [('shape 1', array([[False, ...]]))]
    """
    if type(layer).__name__ == "Shapes":
        if layer.nshapes == 0:
            return []
        masks = np.asarray(layer.to_masks(mask_shape=yx_shape), dtype=bool)
        return [(f"shape {i + 1}", mask) for i, mask in enumerate(masks[:MAX_REGIONS])]
    labels = np.asarray(layer.data)
    if labels.ndim > 2:
        labels = labels.reshape(-1, *labels.shape[-2:]).max(axis=0)
    if labels.shape != tuple(yx_shape):
        return []
    values = np.unique(labels)
    return [(f"label {v}", labels == v) for v in values[values > 0][:MAX_REGIONS]]


@functools.cache
def _widget_class() -> type:
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure
    from qtpy.QtWidgets import QLabel, QVBoxLayout, QWidget

    class SpectrumWidget(QWidget):
        def __init__(self, viewer: Any) -> None:
            super().__init__()
            self.viewer = viewer
            self.figure = Figure(figsize=(4.5, 3.2), layout="constrained")
            self.axes = self.figure.add_subplot()
            self.canvas = FigureCanvasQTAgg(self.figure)
            self.provenance = QLabel("click a pixel of a cube, or draw a region on it")
            self.provenance.setWordWrap(True)
            layout = QVBoxLayout(self)
            layout.addWidget(self.canvas, stretch=1)
            layout.addWidget(self.provenance)
            self.shown: tuple[Any, Any] | None = None
            self.shown_regions: dict[str, RegionSpectrum] = {}
            viewer.mouse_drag_callbacks.append(self._on_click)
            viewer.layers.events.inserted.connect(self._on_inserted)
            for layer in viewer.layers:
                self._watch(layer)

        def cube_layer(self) -> Any | None:
            """The layer whose spectra are shown."""
            cubes = [layer for layer in self.viewer.layers if _is_cube(layer)]
            active = self.viewer.layers.selection.active
            return active if active in cubes else (cubes[0] if cubes else None)

        def _on_click(self, viewer: Any, event: Any) -> None:
            active = viewer.layers.selection.active
            if active is not None and _is_region_layer(active) and active.mode != "pan_zoom":
                return  # the click draws a region: its spectrum follows from the layer
            layer = self.cube_layer()
            if layer is not None:
                self.show_spectrum(layer, layer.world_to_data(event.position))

        def _on_inserted(self, event: Any) -> None:
            self._watch(event.value)
            if _is_region_layer(event.value):
                self.show_regions(event.value)

        def _watch(self, layer: Any) -> None:
            if not _is_region_layer(layer):
                return
            update = functools.partial(self._on_region_changed, layer)
            layer.events.data.connect(update)
            if hasattr(layer.events, "paint"):
                layer.events.paint.connect(update)

        def _on_region_changed(self, layer: Any, event: Any) -> None:
            action = str(getattr(event, "action", "") or "")
            if action in ("adding", "changing", "removing"):
                return  # the shape is still being drawn or moved
            self.show_regions(layer)

        def _show_provenance(self, layer: Any) -> None:
            # Long values (a checksum) cut to keep the dock narrow; whole in the tooltip.
            self.provenance.setText(provenance_text(layer.metadata, shorten=36))
            self.provenance.setToolTip(provenance_text(layer.metadata))

        def _title(self, layer: Any, what: str) -> str:
            bundle = bundle_name(layer.metadata)
            return f"{layer.name}: {what}" + (f"\nbundle {bundle}" if bundle else "")

        def _axes_labels(self, layer: Any) -> None:
            self.axes.set_xlabel("wavelength (nm)")
            self.axes.set_ylabel(layer.metadata.get("units") or "value")

        def show_spectrum(self, layer: Any, position: Any) -> None:
            """Plot the spectrum at ``position`` (data coordinates of ``layer``)."""
            wav, values = pixel_spectrum(layer.data, layer.metadata, position)
            self._show_provenance(layer)
            if wav.size == 0:
                return
            y, x = (round(float(v)) for v in position[-2:])
            self.axes.clear()
            self.axes.plot(wav, values)
            self._axes_labels(layer)
            self.axes.set_title(self._title(layer, f"pixel (x {x}, y {y})"), fontsize="small")
            self.canvas.draw_idle()
            self.shown = (wav, values)

        def show_regions(self, region_layer: Any) -> None:
            """Plot the mean spectrum and its standard deviation band of each region of
            ``region_layer`` (a Shapes or Labels layer drawn on the cube's pixel grid)."""
            cube = self.cube_layer()
            if cube is None:
                return
            self._show_provenance(cube)
            grid = slice(-2, None)
            if not (
                np.allclose(region_layer.scale[grid], cube.scale[grid])
                and np.allclose(region_layer.translate[grid], cube.translate[grid])
            ):
                self.provenance.setText(
                    f"{region_layer.name} is not on the pixel grid of {cube.name}: draw the "
                    f"region on a layer with the cube's scale and translate"
                )
                return
            yx_shape = tuple(int(n) for n in cube.data.shape[-2:])
            time_index = int(self.viewer.dims.current_step[0]) if cube.ndim == 4 else None
            spectra = {
                name: region_spectrum(cube.data, cube.metadata, mask, time_index)
                for name, mask in region_masks(region_layer, yx_shape)
            }
            spectra = {name: s for name, s in spectra.items() if s.pixels}
            self.shown_regions = spectra
            if not spectra:
                return
            self.axes.clear()
            for name, s in spectra.items():
                (line,) = self.axes.plot(s.wavelengths_nm, s.mean, label=f"{name} ({s.pixels} px)")
                self.axes.fill_between(
                    s.wavelengths_nm, s.mean - s.std, s.mean + s.std, color=line.get_color(),
                    alpha=0.25, linewidth=0,
                )  # fmt: skip
            self._axes_labels(cube)
            self.axes.legend(fontsize="x-small", title="mean ± std", title_fontsize="x-small")
            what = f"{region_layer.name} (mean of each region)"
            self.axes.set_title(self._title(cube, what), fontsize="small")
            self.canvas.draw_idle()

    return SpectrumWidget
