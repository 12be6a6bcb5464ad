"""Spectral scenes of the virtual bench, on the SLM grid plus a margin.

A scene is a reflectance cube r(row, col, wavelength) over a *canvas*: the SLM grid
extended by ``margin`` pixels on every side, so the guide camera can see past the
SLM's edges. Cubes are never stored whole (the prototype scale would need gigabytes):
a scene is either a label image with one spectrum per label (:class:`LabelScene`) or
coefficient images over a few basis spectra (:class:`BasisScene`). Both answer the
same three questions fast: the reflectance image at one wavelength, the spectra of a
set of pixels, and projections onto spectral weights (for RGB rendering).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError
from sassi_bench.optics.datasets import photo_loader, require_dataset
from sassi_bench.rig.rig import check_scene
from sassi_bench.rig.scene_pose import ScenePose

__all__ = [
    "BasisScene",
    "LabelScene",
    "Scene",
    "ScenePose",
    "colorchecker_scene",
    "interpolate_rows",
    "make_scene",
    "natural_scene",
    "pcb_scene",
    "posed_scene",
    "white_scene",
]


def interpolate_rows(table: NDArray[np.float64], grid: NDArray[np.float64], lam: ArrayLike):
    """Linearly interpolate each row of ``table`` (defined on ``grid``) at ``lam``.

    Examples
    --------
    >>> interpolate_rows(np.array([[0.0, 1.0]]), np.array([400.0, 500.0]), [450.0]).tolist()
    [[0.5]]
    """
    lam = np.atleast_1d(np.asarray(lam, dtype=np.float64))
    pos = np.clip(np.searchsorted(grid, lam) - 1, 0, grid.size - 2)
    frac = np.clip((lam - grid[pos]) / (grid[pos + 1] - grid[pos]), 0.0, 1.0)
    return table[:, pos] * (1.0 - frac) + table[:, pos + 1] * frac


@dataclass
class Scene(ABC):
    """A reflectance cube on a canvas (the SLM grid plus ``margin`` on each side)."""

    name: str
    wavelengths_nm: NDArray[np.float64]
    margin: int

    @property
    @abstractmethod
    def canvas_shape(self) -> tuple[int, int]:
        """(height, width) of the canvas."""

    @abstractmethod
    def reflectance_image(self, wavelength_nm: float) -> NDArray[np.float32]:
        """Reflectance over the canvas at one wavelength (linear interpolation)."""

    @abstractmethod
    def reflectance_at(
        self, rows: ArrayLike, cols: ArrayLike, wavelengths_nm: ArrayLike
    ) -> NDArray[np.float32]:
        """Spectra (N, K) of canvas pixels (rows, cols) at ``wavelengths_nm``."""

    @abstractmethod
    def project(self, weights: NDArray[np.float64]) -> NDArray[np.float32]:
        """Per-pixel sums ``sum_l weights[c, l] r(., lambda_l)``: (C, H, W) on the canvas."""

    def slm_window(self, slm_shape: tuple[int, int]) -> tuple[slice, slice]:
        """Canvas slices that the SLM sees."""
        m = self.margin
        return slice(m, m + slm_shape[0]), slice(m, m + slm_shape[1])

    def cube(self, slm_shape: tuple[int, int]) -> NDArray[np.float32]:
        """The reflectance cube (H, W, L) on the SLM grid, materialised."""
        rows, cols = self.slm_window(slm_shape)
        eye = np.eye(self.wavelengths_nm.size)
        return np.moveaxis(self.project(eye)[:, rows, cols], 0, -1)


@dataclass
class LabelScene(Scene):
    """A scene of flat regions: ``labels`` (H, W) index rows of ``spectra`` (n, L)."""

    labels: NDArray[np.intp] = None  # type: ignore[assignment]
    spectra: NDArray[np.float64] = None  # type: ignore[assignment]

    @property
    def canvas_shape(self) -> tuple[int, int]:
        return tuple(self.labels.shape)  # type: ignore[return-value]

    def reflectance_image(self, wavelength_nm: float) -> NDArray[np.float32]:
        per_label = interpolate_rows(self.spectra, self.wavelengths_nm, wavelength_nm)[:, 0]
        return per_label.astype(np.float32)[self.labels]

    def reflectance_at(self, rows, cols, wavelengths_nm) -> NDArray[np.float32]:
        table = interpolate_rows(self.spectra, self.wavelengths_nm, wavelengths_nm).astype(
            np.float32
        )
        return table[self.labels[np.asarray(rows), np.asarray(cols)]]

    def project(self, weights: NDArray[np.float64]) -> NDArray[np.float32]:
        per_label = (self.spectra @ np.asarray(weights, dtype=np.float64).T).astype(np.float32)
        return np.moveaxis(per_label[self.labels], -1, 0)


@dataclass
class BasisScene(Scene):
    """A scene ``r = sum_k coefficients[k] * basis[k]`` (coefficients (K, H, W), basis (K, L))."""

    coefficients: NDArray[np.float32] = None  # type: ignore[assignment]
    basis: NDArray[np.float64] = None  # type: ignore[assignment]

    @property
    def canvas_shape(self) -> tuple[int, int]:
        return tuple(self.coefficients.shape[1:])  # type: ignore[return-value]

    def reflectance_image(self, wavelength_nm: float) -> NDArray[np.float32]:
        b = interpolate_rows(self.basis, self.wavelengths_nm, wavelength_nm)[:, 0].astype(
            np.float32
        )
        return np.tensordot(b, self.coefficients, axes=1)

    def reflectance_at(self, rows, cols, wavelengths_nm) -> NDArray[np.float32]:
        b = interpolate_rows(self.basis, self.wavelengths_nm, wavelengths_nm).astype(np.float32)
        c = self.coefficients[:, np.asarray(rows), np.asarray(cols)]
        return c.T @ b

    def project(self, weights: NDArray[np.float64]) -> NDArray[np.float32]:
        w = (np.asarray(weights, dtype=np.float64) @ self.basis.T).astype(np.float32)
        return np.tensordot(w, self.coefficients, axes=1)


def _canvas(slm_shape: tuple[int, int], margin: int) -> tuple[int, int]:
    return slm_shape[0] + 2 * margin, slm_shape[1] + 2 * margin


def white_scene(
    slm_shape: tuple[int, int], grid: NDArray[np.float64], margin: int, reflectance: float = 0.98
) -> LabelScene:
    """A flat white diffuser filling the view (a Spectralon-like target).

    Examples
    --------
    >>> s = white_scene((4, 6), np.array([400.0, 700.0]), margin=1)
    >>> s.reflectance_image(550.0).shape
    (6, 8)
    """
    labels = np.zeros(_canvas(slm_shape, margin), dtype=np.intp)
    spectra = np.full((1, grid.size), reflectance)
    return LabelScene("white", grid, margin, labels=labels, spectra=spectra)


# Patch names of colour-science's ColorChecker data, in chart reading order.
CHECKER_ROWS, CHECKER_COLS = 4, 6
CHECKER_ASPECT = 279.4 / 215.9  # X-Rite ColorChecker Classic, width / height


def colorchecker_layout(
    slm_shape: tuple[int, int], margin: int, rotation_deg: float
) -> dict[str, float]:
    """Geometry of the simulated chart in canvas pixels (centre, size, pitch, rotation)."""
    h, w = slm_shape
    height = 0.86 * h
    width = height * CHECKER_ASPECT
    if width > 0.9 * w:
        width = 0.9 * w
        height = width / CHECKER_ASPECT
    return {
        "centre_row": margin + (h - 1) / 2.0,
        "centre_col": margin + (w - 1) / 2.0,
        "width": width,
        "height": height,
        "pitch": width / (CHECKER_COLS + 0.45),
        "patch": 0.8 * width / (CHECKER_COLS + 0.45),
        "rotation_deg": rotation_deg,
    }


def colorchecker_scene(
    slm_shape: tuple[int, int],
    grid: NDArray[np.float64],
    margin: int,
    data: str = "BabelColor Average",
    rotation_deg: float = 1.5,
) -> LabelScene:
    """An X-Rite ColorChecker Classic: 4x6 patches in a black surround on a grey card.

    Labels: 0 grey card (0.3), 1 black frame (0.03), 2..25 the 24 patches in reading
    order, with colour-science's reflectances ``data``.
    """
    import colour

    chart = require_dataset("colourchecker", data, "scenes.colorchecker_data")
    shape = colour.SpectralShape(float(grid[0]), float(grid[-1]), float(grid[1] - grid[0]))
    patches = [
        sd.copy().align(shape, extrapolator_kwargs={"method": "Constant"}).values
        for sd in chart.values()
    ]
    spectra = np.vstack([np.full(grid.size, 0.30), np.full(grid.size, 0.03), *patches])
    lay = colorchecker_layout(slm_shape, margin, rotation_deg)
    hh, ww = _canvas(slm_shape, margin)
    rows, cols = np.mgrid[0:hh, 0:ww].astype(np.float64)
    t = np.deg2rad(rotation_deg)
    dr, dc = rows - lay["centre_row"], cols - lay["centre_col"]
    # Chart-local coordinates (rotate the canvas back by the chart's rotation).
    lc = np.cos(t) * dc + np.sin(t) * dr + lay["width"] / 2.0
    lr = -np.sin(t) * dc + np.cos(t) * dr + lay["height"] / 2.0
    inside = (lc >= 0) & (lc < lay["width"]) & (lr >= 0) & (lr < lay["height"])
    x0 = (lay["width"] - CHECKER_COLS * lay["pitch"]) / 2.0
    y0 = (lay["height"] - CHECKER_ROWS * lay["pitch"]) / 2.0
    pc = np.floor((lc - x0) / lay["pitch"])
    pr = np.floor((lr - y0) / lay["pitch"])
    fc = (lc - x0) - pc * lay["pitch"]
    fr = (lr - y0) - pr * lay["pitch"]
    gap = (lay["pitch"] - lay["patch"]) / 2.0
    in_patch = (
        inside
        & (pc >= 0) & (pc < CHECKER_COLS) & (pr >= 0) & (pr < CHECKER_ROWS)
        & (fc >= gap) & (fc < lay["pitch"] - gap) & (fr >= gap) & (fr < lay["pitch"] - gap)
    )  # fmt: skip
    labels = np.where(inside, 1, 0).astype(np.intp)
    labels[in_patch] = 2 + (pr[in_patch] * CHECKER_COLS + pc[in_patch]).astype(np.intp)
    return LabelScene("colorchecker", grid, margin, labels=labels, spectra=spectra)


def _sigmoid(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return 1.0 / (1.0 + np.exp(-x))


def pcb_scene(
    slm_shape: tuple[int, int], grid: NDArray[np.float64], margin: int, seed: int
) -> LabelScene:
    """Fine metal tracks on a green solder-mask PCB, with gold pads and silkscreen.

    Tracks are 1-3 px wide Manhattan/45 degree routes drawn with OpenCV; the layout is
    reproducible from ``seed``. Labels: 0 solder mask, 1 copper under mask, 2 gold
    (ENIG) pads, 3 white silkscreen.
    """
    import cv2

    rng = np.random.default_rng(seed)
    hh, ww = _canvas(slm_shape, margin)
    img = np.zeros((hh, ww), dtype=np.uint8)
    scale = max(hh, ww) / 800.0
    for _ in range(int(160 * scale**2)):
        x, y = rng.integers(0, ww), rng.integers(0, hh)
        thickness = int(rng.integers(1, 4))
        pts = [(int(x), int(y))]
        for _ in range(int(rng.integers(2, 5))):
            length = int(rng.integers(10, 120) * scale)
            dx, dy = [(1, 0), (0, 1), (1, 1), (1, -1), (-1, 0), (0, -1)][rng.integers(0, 6)]
            x, y = x + dx * length, y + dy * length
            pts.append((int(x), int(y)))
        cv2.polylines(img, [np.array(pts, np.int32)], False, 1, thickness)
        if rng.random() < 0.6:
            cv2.circle(img, pts[-1], int(rng.integers(3, 7) * scale), 2, -1)
    for _ in range(int(30 * scale**2)):  # rows of SMD pads
        x, y = int(rng.integers(0, ww)), int(rng.integers(0, hh))
        size = int(rng.integers(3, 8) * scale)
        for k in range(int(rng.integers(3, 9))):
            cv2.rectangle(
                img, (x + k * 2 * size, y), (x + k * 2 * size + size, y + 2 * size), 2, -1
            )
    for _ in range(int(12 * scale**2)):  # silkscreen outlines and reference designators
        x, y = int(rng.integers(0, ww)), int(rng.integers(0, hh))
        w, h = int(rng.integers(20, 80) * scale), int(rng.integers(15, 60) * scale)
        cv2.rectangle(img, (x, y), (x + w, y + h), 3, 1)
        label = f"{'RCUQL'[rng.integers(0, 5)]}{rng.integers(1, 99)}"
        cv2.putText(img, label, (x + 2, y - 3), cv2.FONT_HERSHEY_PLAIN, 0.8 * scale, 3, 1)
    lam = grid
    mask = 0.04 + 0.22 * np.exp(-(((lam - 525) / 38) ** 2)) + 0.06 * _sigmoid((lam - 680) / 15)
    copper = 0.08 + 0.30 * np.exp(-(((lam - 535) / 42) ** 2)) + 0.18 * _sigmoid((lam - 600) / 20)
    gold = 0.32 + 0.58 * _sigmoid((lam - 515) / 22)
    silk = 0.82 - 0.25 * np.exp(-(lam - 390) / 25)
    spectra = np.clip(np.vstack([mask, copper, gold, silk]), 0.0, 1.0)
    return LabelScene("pcb", grid, margin, labels=img.astype(np.intp), spectra=spectra)


def _photo(name: str) -> NDArray[np.float64]:
    image = np.asarray(photo_loader(name)(), dtype=np.float64)
    if image.ndim != 3 or image.shape[2] < 3:
        raise ConfigError(f"scenes.natural_image: {name!r} is not a colour image")
    return image[..., :3] / 255.0


def natural_scene(
    slm_shape: tuple[int, int],
    grid: NDArray[np.float64],
    margin: int,
    image: str = "coffee",
    components: int = 12,
    chunk: int = 1 << 18,
) -> BasisScene:
    """A real photograph lifted to plausible reflectance spectra.

    The sRGB photo (scikit-image data) is cropped to the canvas aspect, resized with
    anti-aliasing, converted to CIE XYZ and lifted pixel by pixel with the vectorised
    Otsu et al. (2018) method. The spectra are then compressed to their first
    ``components`` principal components (reflectances stay within about 0.015 of
    [0, 1]), processed in chunks so memory stays bounded at the prototype's scale.
    """
    import colour
    from scipy.interpolate import CubicSpline
    from skimage.transform import resize

    from sassi_bench.rig.sim.otsu import OTSU2018_WAVELENGTHS_NM, xyz_to_reflectance_otsu2018

    hh, ww = _canvas(slm_shape, margin)
    photo = _photo(image)
    ph, pw = photo.shape[:2]
    target = ww / hh
    if pw / ph > target:
        keep = round(ph * target)
        photo = photo[:, (pw - keep) // 2 : (pw - keep) // 2 + keep]
    else:
        keep = round(pw / target)
        photo = photo[(ph - keep) // 2 : (ph - keep) // 2 + keep]
    rgb = resize(photo, (hh, ww), anti_aliasing=True, order=1).reshape(-1, 3)
    xyz = colour.sRGB_to_XYZ(np.clip(rgb, 0.0, 1.0))
    # Pass 1: second moments of the spectra; pass 2: projection on the principal axes.
    otsu_wl = OTSU2018_WAVELENGTHS_NM()
    moment = np.zeros((otsu_wl.size, otsu_wl.size))
    for start in range(0, xyz.shape[0], chunk):
        spectra = xyz_to_reflectance_otsu2018(xyz[start : start + chunk])
        moment += spectra.T @ spectra
    _, vectors = np.linalg.eigh(moment)
    axes = vectors[:, ::-1][:, :components]  # (36, K), strongest first
    coefficients = np.empty((components, xyz.shape[0]), dtype=np.float32)
    for start in range(0, xyz.shape[0], chunk):
        spectra = xyz_to_reflectance_otsu2018(xyz[start : start + chunk])
        coefficients[:, start : start + chunk] = (spectra @ axes).T
    basis = CubicSpline(otsu_wl, axes, axis=0)(grid).T  # (K, L)
    return BasisScene(
        "natural",
        grid,
        margin,
        coefficients=coefficients.reshape(components, hh, ww),
        basis=basis,
    )


def make_scene(
    name: str,
    slm_shape: tuple[int, int],
    grid: NDArray[np.float64],
    margin: int,
    seed: int = 0,
    colorchecker_data: str = "BabelColor Average",
    colorchecker_rotation_deg: float = 1.5,
    natural_image: str = "coffee",
) -> Scene:
    """Build scene ``name`` (``white``, ``colorchecker``, ``natural`` or ``pcb``).

    Examples
    --------
    >>> grid = np.arange(390.0, 722.0, 2.0)
    >>> make_scene("white", (40, 64), grid, margin=4).canvas_shape
    (48, 72)
    """
    if name == "white":
        return white_scene(slm_shape, grid, margin)
    if name == "colorchecker":
        return colorchecker_scene(
            slm_shape, grid, margin, colorchecker_data, colorchecker_rotation_deg
        )
    if name == "natural":
        return natural_scene(slm_shape, grid, margin, natural_image)
    if name == "pcb":
        return pcb_scene(slm_shape, grid, margin, seed)
    check_scene(name)
    raise AssertionError(f"scene {name!r} is known but has no builder")  # pragma: no cover


def posed_scene(scene: Scene, pose: ScenePose, slm_shape: tuple[int, int]) -> Scene:
    """``scene`` moved to ``pose``, materialised on the same canvas.

    Label scenes are resampled by nearest neighbour (regions stay flat with one
    spectrum each), basis scenes bilinearly per coefficient image; what falls outside
    the static canvas repeats its edge. The result answers the same questions as any
    scene, so the spectral and the guide camera see the same posed scene.

    Examples
    --------
    >>> grid = np.array([400.0, 700.0])
    >>> labels = np.zeros((6, 8), np.intp)
    >>> labels[:, 4:] = 1
    >>> scene = LabelScene("s", grid, 1, labels=labels, spectra=np.eye(2))
    >>> moved = posed_scene(scene, ScenePose((1.0, 0.0)), (4, 6))
    >>> moved.labels[0].tolist()
    [0, 0, 0, 0, 0, 1, 1, 1]
    """
    import cv2

    if pose.is_identity:
        return scene
    matrix = pose.canvas_matrix(slm_shape, scene.margin)
    size = (scene.canvas_shape[1], scene.canvas_shape[0])

    def warp(image: NDArray, interpolation: int) -> NDArray:
        return cv2.warpAffine(
            image,
            matrix,
            size,
            flags=interpolation | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REPLICATE,
        )

    if isinstance(scene, LabelScene):
        labels = warp(scene.labels.astype(np.int32), cv2.INTER_NEAREST).astype(np.intp)
        return LabelScene(
            scene.name, scene.wavelengths_nm, scene.margin, labels=labels, spectra=scene.spectra
        )
    if isinstance(scene, BasisScene):
        coefficients = np.stack([warp(c, cv2.INTER_LINEAR) for c in scene.coefficients])
        return BasisScene(
            scene.name,
            scene.wavelengths_nm,
            scene.margin,
            coefficients=coefficients,
            basis=scene.basis,
        )
    raise TypeError(f"posed_scene: cannot move a {type(scene).__name__}")
