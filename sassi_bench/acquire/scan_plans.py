"""Pinhole-scan plans and the checks of what a scan may ask of the SLM.

A Nyquist pinhole scan opens SLM pixels on a grid (100 px apart horizontally, 5 px
vertically by default) and shifts it through every offset, so every SLM pixel is open in
exactly one of the 100 x 5 = 500 frames (:func:`scan_plan`); the guide registration scans
a coarser lattice of those offsets (:func:`coarse_scan_plan`). :func:`check_pitch` and
:func:`check_roi` refuse a pitch or a region the SLM cannot take before anything is
captured (the pitch against the streaks: :mod:`~sassi_bench.acquire.streak_pitch`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import NamedTuple

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.errors import ConfigError, ProcedureError, step_error

__all__ = [
    "Roi",
    "check_pitch",
    "check_roi",
    "check_stride",
    "coarse_scan_plan",
    "refining_scan_plan",
    "scan_plan",
]


class Roi(NamedTuple):
    """A region of the SLM grid: rows ``row0:row1`` and columns ``col0:col1`` (Python slice
    bounds, the end excluded).

    Examples
    --------
    >>> roi = Roi(10, 20, 30, 40)
    >>> roi.shape, roi.slices
    ((20, 20), (slice(10, 30, None), slice(20, 40, None)))
    """

    row0: int
    col0: int
    row1: int
    col1: int

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the region."""
        return (self.row1 - self.row0, self.col1 - self.col0)

    @property
    def slices(self) -> tuple[slice, slice]:
        """The region as a NumPy index of an SLM-sized array."""
        return (slice(self.row0, self.row1), slice(self.col0, self.col1))


def check_roi(
    roi: Sequence[int] | None, slm_shape: tuple[int, int], step: str = "scan assembly"
) -> Roi:
    """A region ``(row0, col0, row1, col1)`` of the SLM, checked; the whole SLM for None.

    Examples
    --------
    >>> check_roi(None, (400, 640)), check_roi([10, 20, 30, 40], (400, 640))
    (Roi(row0=0, col0=0, row1=400, col1=640), Roi(row0=10, col0=20, row1=30, col1=40))
    """
    h, w = slm_shape
    if roi is None:
        return Roi(0, 0, h, w)
    r0, c0, r1, c1 = (int(v) for v in roi)
    if not (0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w):
        raise ProcedureError(
            step_error(
                step,
                f"the ROI {tuple(roi)} is not a region of the {h} x {w} SLM",
                f"give (row0, col0, row1, col1) with 0 <= row0 < row1 <= {h} and "
                f"0 <= col0 < col1 <= {w}",
            )
        )
    return Roi(r0, c0, r1, c1)


def check_pitch(pitch: tuple[int, int], slm_shape: tuple[int, int]) -> tuple[int, int]:
    """The (horizontal, vertical) pinhole pitch of a scan, checked against the SLM.

    Examples
    --------
    >>> check_pitch((100, 5), (400, 640))
    (100, 5)
    """
    px, py = (int(p) for p in pitch)
    h, w = slm_shape
    if not (1 <= px <= w and 1 <= py <= h):
        raise ProcedureError(
            step_error(
                "pinhole scan",
                f"pitch {tuple(pitch)} px does not fit the {h} x {w} SLM",
                f"give a horizontal pitch of 1..{w} and a vertical one of 1..{h} SLM px "
                "(the Nyquist scan: 100 5)",
            )
        )
    return px, py


def scan_plan(
    slm_shape: tuple[int, int],
    light: str,
    exposure_s: float,
    pitch: tuple[int, int] = (100, 5),
    scene: str | None = None,
    closed_check: bool = True,
) -> Plan:
    """The pinhole scan: every offset of a ``pitch`` grid, one frame each.

    Examples
    --------
    >>> plan = scan_plan((400, 640), "led", 0.1)
    >>> len(plan.select(role="pinholes")), plan.steps[0].tags["role"]
    (500, 'closed')
    """
    px, py = check_pitch(pitch, slm_shape)
    steps = []
    if closed_check:
        steps.append(Step("spectral", light, exposure_s, {"kind": "blank"}, {"role": "closed"}))
    for oy in range(py):
        for ox in range(px):
            pattern = {"kind": "pinholes", "pitch": [px, py], "offset": [ox, oy]}
            steps.append(
                Step(
                    "spectral", light, exposure_s, pattern, {"role": "pinholes", "ox": ox, "oy": oy}
                )
            )
    parameters = {"pitch": [px, py], "light": light, "exposure_s": exposure_s}
    if scene is not None:
        parameters["scene"] = scene
    return Plan("pinhole-scan", tuple(steps), parameters)


def _phase_order(every: int) -> list[int]:
    """``range(every)`` in farthest-first order (on the circle of the pitch): each prefix
    spreads its phases as evenly as it can."""
    order = [0]
    left = list(range(1, every))
    while left:
        gap = [min(min(abs(p - q), every - abs(p - q)) for q in order) for p in left]
        order.append(left.pop(gap.index(max(gap))))
    return order


def refining_scan_plan(plan: Plan, every: int, budget: int) -> Plan:
    """A scan's pinhole frames reordered so that every prefix is a thinned scan: first
    every ``every``-th offset, then the offsets halfway between them, and so on, at most
    ``budget`` pinhole frames (the closed-SLM frame stays first).

    A step that measures until confident captures a prefix, measures, and captures a
    longer prefix if it must; each pinhole frame is tagged with its place (``frame``).

    Examples
    --------
    >>> plan = refining_scan_plan(scan_plan((400, 640), "led", 0.1, (8, 1)), 4, 4)
    >>> [s.tags["ox"] for s in plan.steps[1:]], plan.steps[2].tags["frame"]
    ([0, 4, 2, 6], 1)
    """
    pinholes = [s for s in plan.steps if s.tags.get("role") == "pinholes"]
    closed = [s for s in plan.steps if s.tags.get("role") != "pinholes"]
    ordered = [s for p in _phase_order(every) for i, s in enumerate(pinholes) if i % every == p]
    ordered = [
        replace(s, tags={**s.tags, "frame": k}) for k, s in enumerate(ordered[: max(1, budget)])
    ]
    parameters = {**plan.parameters, "every": every, "max_frames": budget}
    return Plan(plan.name, tuple(closed + ordered), parameters)


def check_stride(pitch: Sequence[int], stride: Sequence[int]) -> tuple[int, int]:
    """A coarse scan's stride, checked to divide the pinhole pitch on each axis.

    Raises
    ------
    ConfigError
        Naming both and the fix.

    Examples
    --------
    >>> check_stride((100, 5), (4, 1))
    (4, 1)
    """
    px, py = int(pitch[0]), int(pitch[1])
    sx, sy = int(stride[0]), int(stride[1])
    if px % sx or py % sy:
        raise ConfigError(
            step_error(
                "guide registration",
                f"scan stride {[sx, sy]} does not divide the pinhole pitch {[px, py]}",
                "choose scan.stride_px dividing scan.pitch_px on each axis (or leave "
                "scan.pitch_px null: it is then derived as a multiple of the stride)",
            )
        )
    return sx, sy


def coarse_scan_plan(
    slm_shape: tuple[int, int],
    light: str,
    exposure_s: float,
    pitch: tuple[int, int],
    stride: tuple[int, int],
    scene: str,
) -> Plan:
    """The pinhole scan restricted to every ``stride``-th offset per axis.

    The measured SLM pixels form a lattice ``stride`` apart, starting at (0, 0); with
    ``stride == (1, 1)`` this is the full Nyquist scan.

    Parameters
    ----------
    slm_shape
        SLM (height, width).
    light
        The light the scan is captured under.
    exposure_s
        Exposure of every pinhole frame.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels.
    stride
        (horizontal, vertical) step between the pinhole offsets kept; each divides the
        pitch on its axis.
    scene
        The scene scanned (recorded in the plan's parameters).

    Returns
    -------
    Plan
        ``guide-scan``: the full scan's dark and reference frames and the kept pinhole
        frames, with ``stride`` among its parameters.

    Raises
    ------
    ConfigError
        If a stride does not divide the pitch.

    Examples
    --------
    >>> plan = coarse_scan_plan((400, 640), "led", 0.1, (100, 5), (4, 1), "natural")
    >>> len(plan.select(role="pinholes")), list(plan.parameters["stride"])
    (125, [4, 1])
    """
    px, py = int(pitch[0]), int(pitch[1])
    sx, sy = check_stride(pitch, stride)
    plan = scan_plan(slm_shape, light, exposure_s, (px, py), scene=scene)
    keep = tuple(
        s
        for s in plan.steps
        if s.tags["role"] != "pinholes" or (s.tags["ox"] % sx == 0 and s.tags["oy"] % sy == 0)
    )
    return Plan("guide-scan", keep, {**plan.parameters, "stride": [sx, sy]})
