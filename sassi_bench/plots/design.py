"""The figure of a spectral arm described as an optical design (``sassi-bench rig show``).

Four panels, as a design program shows a system: the layout (surfaces and rays in the
dispersion plane, drawn by optiland), the spots over the field at three wavelengths as
ellipses on the camera (their covariance, magnified), the predicted dispersion (camera
column against wavelength at the field's centre and corners, relative to 550 nm) and the
spot's widths against wavelength at the centre and a corner.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse

__all__ = ["design_figure"]

_SPOT_NM = (450.0, 550.0, 650.0)
_SPOT_COLOURS = ("tab:blue", "tab:green", "tab:red")
_MAGNIFY = 5.0


def _ellipse(x: float, y: float, cxx: float, cyy: float, cxy: float, colour: str) -> Ellipse:
    """The 1-sigma ellipse of a covariance, magnified, at (x, y)."""
    values, vectors = np.linalg.eigh(np.array([[cxx, cxy], [cxy, cyy]]))
    angle = float(np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1])))
    width, height = 2 * _MAGNIFY * np.sqrt(np.maximum(values[::-1], 0.0))
    return Ellipse((x, y), width, height, angle=angle, fill=False, color=colour, lw=1.0)


def design_figure(relay: Any, optic: Any | None = None, title: str = "") -> Figure:
    """Layout, spots over the field, predicted dispersion and spot widths of a design.

    Parameters
    ----------
    relay
        The traced design (:class:`~sassi_bench.optics.design.relay.DesignRelay`).
    optic
        Its optiland optic, for the layout panel (None: the panel says so).
    title
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = Figure(figsize=(13, 8.5), layout="constrained")
    axes = fig.subplots(2, 2)
    fig.suptitle(title)
    layout, spots, dispersion, widths = axes.ravel()
    if optic is not None:
        optic.draw(ax=layout, projection="XZ", num_rays=5, show=False)
        layout.set_title("layout (x-z: the dispersion plane)")
    else:
        layout.text(0.5, 0.5, "layout: optiland not installed", ha="center", va="center")
        layout.set_axis_off()

    h, w = relay.slm_shape
    hc, wc = relay.camera_shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 5), np.linspace(0, h - 1, 3))
    u, v = u.ravel(), v.ravel()
    for lam, colour in zip(_SPOT_NM, _SPOT_COLOURS, strict=True):
        x, y = relay.forward(u, v, lam)
        cxx, cyy, cxy = relay.optics_covariance(u, v, lam)
        for k in range(u.size):
            spots.add_patch(_ellipse(x[k], y[k], cxx[k], cyy[k], cxy[k], colour))
        spots.plot([], [], color=colour, label=f"{lam:.0f} nm")
    spots.set_xlim(0, wc - 1)
    spots.set_ylim(hc - 1, 0)
    spots.set_aspect("equal")
    spots.set_xlabel("camera x (px)")
    spots.set_ylabel("camera y (px)")
    spots.set_title(f"spots over the field (1 sigma, x{_MAGNIFY:g})")
    spots.legend(loc="upper right", fontsize=8)

    lam = np.linspace(400.0, 700.0, 61)
    points = {
        "centre": relay.slm_centre,
        "top left": (0.0, 0.0),
        "top right": (w - 1.0, 0.0),
        "bottom left": (0.0, h - 1.0),
        "bottom right": (w - 1.0, h - 1.0),
    }
    for name, (pu, pv) in points.items():
        x, y = relay.forward(pu, pv, lam)
        x0, _ = relay.forward(pu, pv, 550.0)
        dispersion.plot(
            lam, x - x0, label=f"{name}: {x[-1] - x[0]:.1f} px, smile {y[-1] - y[0]:+.2f}"
        )
    dispersion.set_xlabel("wavelength (nm)")
    dispersion.set_ylabel("camera x - x(550 nm) (px)")
    dispersion.set_title("predicted dispersion (400-700 nm spread, smile in rows)")
    dispersion.legend(fontsize=8)

    for name in ("centre", "top left"):
        pu, pv = points[name]
        cxx, cyy, cxy = relay.optics_covariance(pu, pv, lam)
        widths.plot(lam, np.sqrt(cxx), label=f"{name}: along the streak")
        widths.plot(lam, np.sqrt(cyy), "--", label=f"{name}: across")
    widths.plot(lam, relay.widest_sigma(lam), "k:", label="widest over the SLM")
    widths.set_xlabel("wavelength (nm)")
    widths.set_ylabel("optics sigma (camera px)")
    widths.set_title("spot widths (traced moments + diffraction core)")
    widths.legend(fontsize=8)
    return fig
