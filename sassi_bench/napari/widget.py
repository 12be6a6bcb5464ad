"""The spectrum dock: the clicked pixel's spectrum in nm, and the cube's provenance.

Qt is imported when the dock is made (napari brings it), so this module imports without it.
"""

from __future__ import annotations

import functools
from typing import Any

from sassi_bench.napari.spectrum import pixel_spectrum, provenance_text

__all__ = ["spectrum_widget"]


def spectrum_widget(napari_viewer: Any) -> Any:
    """A dock that plots the spectrum of the pixel clicked in the viewer (of the selected
    cube layer, else the first cube layer) and shows the cube's bundle and inputs.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        viewer.window.add_dock_widget(spectrum_widget(viewer))
    """
    return _widget_class()(napari_viewer)


def _is_cube(layer: Any) -> bool:
    return "wav" in layer.metadata and not getattr(layer, "rgb", False)


@functools.cache
def _widget_class() -> type:
    from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg
    from matplotlib.figure import Figure
    from qtpy.QtWidgets import QLabel, QVBoxLayout, QWidget

    class SpectrumWidget(QWidget):
        def __init__(self, viewer: Any) -> None:
            super().__init__()
            self.viewer = viewer
            self.figure = Figure(figsize=(4, 3), layout="constrained")
            self.axes = self.figure.add_subplot()
            self.canvas = FigureCanvasQTAgg(self.figure)
            self.provenance = QLabel("click a pixel of a cube")
            self.provenance.setWordWrap(True)
            layout = QVBoxLayout(self)
            layout.addWidget(self.canvas)
            layout.addWidget(self.provenance)
            self.shown: tuple[Any, Any] | None = None
            viewer.mouse_drag_callbacks.append(self._on_click)

        def cube_layer(self) -> Any | None:
            """The layer whose spectra are shown."""
            cubes = [layer for layer in self.viewer.layers if _is_cube(layer)]
            active = self.viewer.layers.selection.active
            return active if active in cubes else (cubes[0] if cubes else None)

        def _on_click(self, viewer: Any, event: Any) -> None:
            layer = self.cube_layer()
            if layer is not None:
                self.show_spectrum(layer, layer.world_to_data(event.position))

        def show_spectrum(self, layer: Any, position: Any) -> None:
            """Plot the spectrum at ``position`` (data coordinates of ``layer``)."""
            wav, values = pixel_spectrum(layer.data, layer.metadata, position)
            self.provenance.setText(provenance_text(layer.metadata))
            if wav.size == 0:
                return
            y, x = (round(float(v)) for v in position[-2:])
            self.axes.clear()
            self.axes.plot(wav, values)
            self.axes.set_xlabel("wavelength (nm)")
            self.axes.set_ylabel(layer.metadata.get("units") or "value")
            self.axes.set_title(f"{layer.name}: pixel (x {x}, y {y})", fontsize="small")
            self.canvas.draw_idle()
            self.shown = (wav, values)

    return SpectrumWidget
