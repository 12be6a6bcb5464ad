"""Views of a rig: a few frames saved as images (PNG and 16-bit TIFF), so a person can look."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.atomic import atomic_path, atomic_write_bytes
from sassi_bench.acquire.patterns import pinhole_pattern
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.errors import ProcedureError, SassiBenchError, step_error
from sassi_bench.rig.frame import Frame
from sassi_bench.rig.rig import Rig

__all__ = ["VIEWS", "save_frame", "save_views"]


def _display_8bit(data: NDArray) -> NDArray[np.uint8]:
    lo, hi = np.percentile(data, [0.5, 99.9])
    scaled = (data.astype(np.float64) - lo) / max(hi - lo, 1e-9)
    return (np.clip(scaled, 0, 1) ** (1 / 2.2) * 255).round().astype(np.uint8)


#: The views :func:`save_views` saves, each as ``<name>.tiff`` and ``<name>.png``.
VIEWS = ("guide", "spectral_all_open", "spectral_pinholes")


def _outputs(stem: Path) -> list[Path]:
    return [stem.with_suffix(".tiff"), stem.with_suffix(".png")]


def _check_free(paths: list[Path]) -> None:
    taken = [p for p in paths if p.exists()]
    if taken:
        raise SassiBenchError(
            step_error(
                "rig snapshot",
                f"{taken[0]} already exists",
                "choose another --out folder (images are never replaced)",
            )
        )


def save_frame(frame: Frame, stem: Path) -> list[Path]:
    """Save a frame as ``stem.tiff`` (raw values) and ``stem.png`` (display stretch), each
    written under a temporary name and renamed when complete, never over a file."""
    import cv2
    import tifffile

    stem.parent.mkdir(parents=True, exist_ok=True)
    tiff, png = _outputs(stem)
    _check_free([tiff, png])
    with atomic_path(tiff, overwrite=False) as temporary:
        tifffile.imwrite(temporary, frame.data, metadata={"meta": frame.meta.to_dict()})
    image = _display_8bit(frame.data)
    if image.ndim == 3:
        image = image[..., ::-1]  # OpenCV writes BGR
    _, encoded = cv2.imencode(".png", np.ascontiguousarray(image))
    atomic_write_bytes(png, encoded.tobytes(), overwrite=False)
    return [tiff, png]


def save_views(rig: Rig, out: Path, scene: str = "colorchecker", light: str = "led") -> list[Path]:
    """Capture a guide image and spectral frames (all-open SLM, pinholes) into ``out``.

    Returns
    -------
    list of Path
        The files written.

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        from sassi_bench import open_rig
        files = save_views(open_rig("sim"), Path("snapshot"))
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ProcedureError(
            step_error("rig snapshot", f"{out} is a file, not a folder", "give --out a folder")
        )
    _check_free([path for name in VIEWS for path in _outputs(out / name)])  # before capturing
    written = []
    for name, frame in capture_views(rig, scene, light).items():
        written += save_frame(frame, out / name)
    return written


def capture_views(rig: Rig, scene: str = "colorchecker", light: str = "led") -> dict[str, Frame]:
    """A guide image and spectral frames with the SLM all open and with pinholes.

    Returns
    -------
    dict
        ``guide``, ``spectral_all_open`` and ``spectral_pinholes`` frames.

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        from sassi_bench import open_rig
        sorted(capture_views(open_rig("sim")))
        # ['guide', 'spectral_all_open', 'spectral_pinholes']
    """
    rig.set_scene(scene)
    rig.light.select(light)
    with armed(rig):
        rig.slm.show(np.zeros(rig.slm.shape, dtype=bool))
        views = {"guide": rig.guide_camera.capture()}
        rig.slm.show(np.ones(rig.slm.shape, dtype=bool))
        views["spectral_all_open"] = rig.spectral_camera.capture()
        rig.slm.show(pinhole_pattern(rig.slm.shape))
        views["spectral_pinholes"] = rig.spectral_camera.capture()
    return views
