"""A design traced on a grid over the SLM and the band: what the virtual bench renders from.

At every node (SLM column, SLM row, wavelength) of a regular grid: the chief ray's
position on the camera, the spot's centroid and second moments (camera px) and its
relative throughput (the share of the pupil that reaches the camera: vignetting).

The moments come from a Gauss quadrature over the pupil (Gauss-Legendre in r**2 times
equally spaced angles), not from a spot diagram's equal-weight rings: on the shipped
designs 64 quadrature rays give the second moments to better than 1e-4 px, where a
hexapolar spot diagram of 1261 rays is still 0.06-0.21 px off
(docs/notes/2026-11-29-optical_design.md).
All points of a wavelength go through the tracer in one vectorised call.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial.legendre import leggauss
from numpy.typing import NDArray

from sassi_bench.optics.design.build import build_design
from sassi_bench.optics.design.schema import OpticalDesign

__all__ = ["GridSpec", "TracedGrid", "pupil_quadrature", "trace_grid"]


def pupil_quadrature(rings: int = 4) -> tuple[NDArray, NDArray, NDArray]:
    """Pupil points (Px, Py) in the unit disc and weights summing to 1.

    Gauss-Legendre in r**2 (``rings`` rings) times ``4 rings`` angles (alternate rings
    offset by half a step): exact for polynomials in (Px, Py) of degree up to
    ``4 rings - 1`` over the disc.

    Examples
    --------
    >>> px, py, w = pupil_quadrature(4)
    >>> px.size, round(float(w.sum()), 12), round(float(np.sum(w * px**2)), 12)
    (64, 1.0, 0.25)
    """
    s, ws = leggauss(rings)
    s, ws = 0.5 * (s + 1.0), 0.5 * ws
    m = 4 * rings
    k = np.arange(rings)[:, None]
    theta = 2 * np.pi * (np.arange(m)[None, :] + 0.5 * (k % 2)) / m
    r = np.sqrt(s)[:, None]
    px = (r * np.cos(theta)).ravel()
    py = (r * np.sin(theta)).ravel()
    w = np.repeat(ws / m, m)
    return px, py, w


@dataclass(frozen=True)
class GridSpec:
    """The nodes a design is traced at.

    Parameters
    ----------
    slm_shape, camera_shape
        (height, width) of the SLM and the camera.
    start_nm, stop_nm, step_nm
        The wavelength nodes (inclusive).
    columns, rows
        Field nodes across the SLM (evenly spaced, reaching ``margin`` of the SLM's size
        beyond each edge).
    rings
        Pupil quadrature rings (``16 rings**2 / 4`` rays: 64 for 4 rings).

    Examples
    --------
    >>> spec = GridSpec((400, 640), (512, 800), 380.0, 730.0, 10.0)
    >>> spec.u_nodes().size, spec.wavelengths_nm()[[0, -1]].tolist()
    (17, [380.0, 730.0])
    """

    slm_shape: tuple[int, int]
    camera_shape: tuple[int, int]
    start_nm: float
    stop_nm: float
    step_nm: float = 10.0
    columns: int = 17
    rows: int = 11
    rings: int = 4
    margin: float = 0.08

    def u_nodes(self) -> NDArray[np.float64]:
        """SLM columns of the field nodes."""
        w = self.slm_shape[1] - 1
        return np.linspace(-self.margin * w, (1 + self.margin) * w, self.columns)

    def v_nodes(self) -> NDArray[np.float64]:
        """SLM rows of the field nodes."""
        h = self.slm_shape[0] - 1
        return np.linspace(-self.margin * h, (1 + self.margin) * h, self.rows)

    def wavelengths_nm(self) -> NDArray[np.float64]:
        """The wavelength nodes."""
        n = round((self.stop_nm - self.start_nm) / self.step_nm) + 1
        return np.linspace(self.start_nm, self.start_nm + (n - 1) * self.step_nm, n)

    def to_mapping(self) -> dict[str, object]:
        """The spec as JSON keys (part of the cache key)."""
        return {
            "slm_shape": list(self.slm_shape),
            "camera_shape": list(self.camera_shape),
            "start_nm": self.start_nm,
            "stop_nm": self.stop_nm,
            "step_nm": self.step_nm,
            "columns": self.columns,
            "rows": self.rows,
            "rings": self.rings,
            "margin": self.margin,
        }


#: The per-node arrays of a traced grid, each (columns, rows, wavelengths).
GRID_ARRAYS = ("chief_x", "chief_y", "x", "y", "sxx", "syy", "sxy", "throughput")


@dataclass
class TracedGrid:
    """A design traced on a :class:`GridSpec` (arrays (columns, rows, wavelengths)).

    ``x, y`` are the spot centroids (camera px), ``sxx, syy, sxy`` its geometric second
    central moments (camera px**2), ``chief_x, chief_y`` the chief ray,
    ``throughput`` the share of the pupil that arrives (1: no vignetting).
    ``image_na`` is the image-side numerical aperture at the field centre and the
    reference wavelength (the diffraction core's width follows from it).
    """

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    wavelengths_nm: NDArray[np.float64]
    chief_x: NDArray[np.float64]
    chief_y: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    sxx: NDArray[np.float64]
    syy: NDArray[np.float64]
    sxy: NDArray[np.float64]
    throughput: NDArray[np.float64]
    image_na: float
    seconds: float = 0.0
    meta: dict[str, str] = field(default_factory=dict)


def trace_grid(
    design: OpticalDesign,
    spec: GridSpec,
    progress: Callable[[int, int], None] | None = None,
) -> TracedGrid:
    """Trace ``design`` at every node of ``spec`` (needs optiland).

    Parameters
    ----------
    design
        The design.
    spec
        The nodes.
    progress
        Called with (wavelengths done, wavelengths) after each wavelength.

    Returns
    -------
    TracedGrid
    """
    start = time.perf_counter()
    built = build_design(design, spec.slm_shape, spec.camera_shape)
    u, v, lam = spec.u_nodes(), spec.v_nodes(), spec.wavelengths_nm()
    uu, vv = np.meshgrid(u, v, indexing="ij")
    hx, hy = built.field_of(uu.ravel(), vv.ravel())
    qx, qy, qw = pupil_quadrature(spec.rings)
    n_points, n_rays = hx.size, qx.size
    shape = (u.size, v.size, lam.size)
    out = {name: np.full(shape, np.nan) for name in GRID_ARRAYS}
    field_x, field_y = np.repeat(hx, n_rays), np.repeat(hy, n_rays)
    pupil_x, pupil_y = np.tile(qx, n_points), np.tile(qy, n_points)
    weights = np.tile(qw, n_points).reshape(n_points, n_rays)
    zeros = np.zeros(n_points)
    image_na = float("nan")
    for k, wl in enumerate(lam):
        cx, cy, calive, _, _ = built.trace(hx, hy, zeros, zeros, float(wl))
        out["chief_x"][..., k] = np.where(calive, cx, np.nan).reshape(shape[:2])
        out["chief_y"][..., k] = np.where(calive, cy, np.nan).reshape(shape[:2])
        x, y, alive, dl, dm = built.trace(field_x, field_y, pupil_x, pupil_y, float(wl))
        x, y, alive = (a.reshape(n_points, n_rays) for a in (x, y, alive))
        w = np.where(alive, weights, 0.0)
        total = w.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            xs, ys = np.where(alive, x, 0.0), np.where(alive, y, 0.0)
            mx = (w * xs).sum(1) / total
            my = (w * ys).sum(1) / total
            dx, dy = xs - mx[:, None], ys - my[:, None]
            moments = {
                "x": mx,
                "y": my,
                "sxx": (w * dx * dx).sum(1) / total,
                "syy": (w * dy * dy).sum(1) / total,
                "sxy": (w * dx * dy).sum(1) / total,
                "throughput": total,
            }
        for name, value in moments.items():
            out[name][..., k] = value.reshape(shape[:2])
        if abs(wl - design.reference_nm) <= 0.5 * spec.step_nm and not np.isfinite(image_na):
            centre = int(np.argmin(np.hypot(hx, hy)))
            keep = alive[centre]
            lm = np.stack(
                [dl.reshape(n_points, n_rays)[centre], dm.reshape(n_points, n_rays)[centre]]
            )
            wc = weights[centre] * keep
            mean = (lm * wc).sum(1) / wc.sum()
            var = (((lm - mean[:, None]) ** 2) * wc).sum(1) / wc.sum()
            # a uniformly filled cone of half-angle NA: each direction cosine varies by NA**2 / 4
            image_na = float(2.0 * np.sqrt(var.mean()))
        if progress is not None:
            progress(k + 1, lam.size)
    return TracedGrid(
        u=u,
        v=v,
        wavelengths_nm=lam,
        image_na=image_na,
        seconds=time.perf_counter() - start,
        **out,
    )
