"""Where a scene sits in front of the bench: the pose of a moving scene.

A pose is plain data that procedures may set (a translation and rotation stage, or
the virtual bench's moving scenes); it knows nothing of any backend.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ProcedureError, step_error

__all__ = ["ScenePose"]


@dataclass(frozen=True)
class ScenePose:
    """Where a scene sits: shifted by ``shift_px`` and rotated about the SLM's centre.

    ``shift_px`` is (right, down) in SLM pixels; ``rotation_deg`` turns the scene
    counter-clockwise as seen on the SLM (image axes, rows down). The identity pose is
    today's static scene.

    Examples
    --------
    >>> ScenePose().is_identity, ScenePose.at_frame(3, (1.0, 0.5), 0.2).shift_px
    (True, (3.0, 1.5))
    """

    shift_px: tuple[float, float] = (0.0, 0.0)
    rotation_deg: float = 0.0

    def __post_init__(self) -> None:
        dx, dy = (float(v) for v in self.shift_px)
        angle = float(self.rotation_deg)
        if not all(np.isfinite((dx, dy, angle))):
            raise ProcedureError(
                step_error("scene pose", f"{self!r} is not finite", "use finite numbers")
            )
        object.__setattr__(self, "shift_px", (dx, dy))
        object.__setattr__(self, "rotation_deg", angle)

    @property
    def is_identity(self) -> bool:
        """Whether the pose leaves the scene where it is."""
        return self.shift_px == (0.0, 0.0) and self.rotation_deg == 0.0

    @classmethod
    def at_frame(
        cls, frame: int, shift_px_per_frame: tuple[float, float], rotation_deg_per_frame: float
    ) -> ScenePose:
        """The pose after ``frame`` frames of a steady motion (frame 0 is the identity)."""
        dx, dy = (float(v) for v in shift_px_per_frame)
        return cls((frame * dx, frame * dy), frame * float(rotation_deg_per_frame))

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON form, as capture plans store it.

        Examples
        --------
        >>> ScenePose.from_dict(ScenePose((1.5, -2.0), 0.3).to_dict())
        ScenePose(shift_px=(1.5, -2.0), rotation_deg=0.3)
        """
        return {"shift_px": list(self.shift_px), "rotation_deg": self.rotation_deg}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ScenePose:
        """Build a pose from :meth:`to_dict` output."""
        dx, dy = (float(v) for v in data.get("shift_px", (0.0, 0.0)))
        return cls((dx, dy), float(data.get("rotation_deg", 0.0)))

    def canvas_matrix(self, slm_shape: tuple[int, int], margin: int) -> NDArray[np.float64]:
        """2x3 affine map from posed canvas pixels (x, y) back to the static canvas."""
        centre = np.array([margin + (slm_shape[1] - 1) / 2.0, margin + (slm_shape[0] - 1) / 2.0])
        t = np.deg2rad(self.rotation_deg)
        # A scene turned counter-clockwise on screen (rows down) by t: a posed pixel p
        # shows the static pixel R(t) (p - centre - shift) + centre.
        rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
        out = np.empty((2, 3))
        out[:, :2] = rot
        out[:, 2] = centre - rot @ (centre + np.asarray(self.shift_px, dtype=np.float64))
        return out
