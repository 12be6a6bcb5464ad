"""Capture plans of the spectral calibration (device-free: they only describe frames).

Two plans run in turn. The *grey-level* plan measures the SLM's grey-level response
under one laser (uniform patterns), so the sinusoids of the phase-shifting sweep can be
precompensated. The *sweep* plan then captures, laser by laser: a dark frame (light
off), closed (``blank``) and open (``full``) SLM frames, the sweep proper (Gray code and
phase shifting on both axes, or the paper's line sweep) and pinhole frames for the blur.
On a rig with wavelength lamps a third, short plan (:func:`lamp_plan`) captures a sparse
pinhole array under each lamp, whose atomic lines anchor the wavelength axis.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from sassi_bench.acquire.patterns import gray_bit_count
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.streak_pitch import pitch_room
from sassi_bench.errors import ConfigError, ProcedureError, step_error
from sassi_bench.optics.lamps import LineList
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.lights import laser_light

__all__ = [
    "BLUR_LINE_CLEAR_NM",
    "BLUR_LINE_MARGIN_NM",
    "BLUR_LINE_MIN_INTENSITY",
    "BLUR_LINE_NEIGHBOUR_SHARE",
    "LAMP_FIELD_OFFSETS",
    "LAMP_MARGIN_PX",
    "LAMP_PINHOLE_PITCH_PX",
    "LAMP_REACH_SIGMAS",
    "blur_lamp_lines",
    "blur_pinholes",
    "blur_plan",
    "check_lamp_pitch",
    "grey_levels",
    "grey_plan",
    "lamp_band",
    "lamp_field_pinholes",
    "lamp_pinholes",
    "lamp_plan",
    "sweep_plan",
]

#: Pinhole pitch (SLM px, [x, y]) of the lamp frames when the procedure leaves it out: a
#: lamp streak's 400-710 nm lines and their blur must not reach the next pinhole's.
LAMP_PINHOLE_PITCH_PX = (100, 24)
#: A lamp streak is cut from 4 spot sigmas before its first line to 4 after its last;
#: its neighbours are kept this many camera px further away.
LAMP_REACH_SIGMAS = 4.0
LAMP_MARGIN_PX = 1.0


def grey_levels(count: int) -> list[int]:
    """``count`` grey levels spread over 0..255, always including both ends.

    Parameters
    ----------
    count
        How many levels (fewer when rounding makes two equal).

    Returns
    -------
    list of int
        Sorted, distinct, from 0 to 255.

    Examples
    --------
    >>> grey_levels(5)
    [0, 64, 128, 191, 255]
    """
    return sorted({int(np.rint(x)) for x in np.linspace(0, 255, count)})


def grey_plan(procedure: Mapping[str, Any], laser_nm: float, exposure_s: float) -> Plan:
    """Uniform SLM grey levels under one laser, plus a dark frame.

    Parameters
    ----------
    procedure
        The validated spectral-calibration procedure (``sweep.grey_levels``).
    laser_nm
        The laser the response is measured under.
    exposure_s
        Exposure of every frame, seconds.

    Returns
    -------
    Plan
        Steps tagged ``role: dark`` and ``role: grey`` (with their ``level``).

    Examples
    --------
    >>> from sassi_bench.procedure import load_procedure
    >>> plan = grey_plan(load_procedure("spectral_calibration"), 532.0, 0.05)
    >>> len(plan), plan.steps[0].tags["role"]
    (18, 'dark')
    """
    light = laser_light(laser_nm)
    steps = [Step("spectral", "off", exposure_s, {"kind": "blank"}, {"role": "dark"})]
    for level in grey_levels(int(procedure["sweep"].get("grey_levels", 17))):
        steps.append(
            Step(
                "spectral",
                light,
                exposure_s,
                {"kind": "uniform", "level": level},
                {"role": "grey", "level": level},
            )
        )
    return Plan(
        "spectral-grey",
        tuple(steps),
        {
            "scene": "white",
            "laser_nm": laser_nm,
            "exposure_s": exposure_s,
            "procedure": {k: v for k, v in procedure.items() if k != "source"},
        },
    )


def _frame(light: str, exposure: float, pattern: dict, tags: dict) -> Step:
    """A spectral-camera step (every step of these plans uses that camera)."""
    return Step("spectral", light, exposure, pattern, tags)


def _structured_steps(
    light: str, exposure: float, tags: dict, slm_shape: tuple[int, int], sweep: Mapping, profile
) -> list[Step]:
    block = int(sweep.get("gray_block_px", 8))
    period = int(sweep.get("phase_period_px", 16))
    steps_count = int(sweep.get("phase_steps", 8))
    steps = []
    for axis, length in (("x", slm_shape[1]), ("y", slm_shape[0])):
        for bit in range(gray_bit_count(length, block)):
            for inverse in (False, True):
                pattern = {
                    "kind": "gray",
                    "axis": axis,
                    "bit": bit,
                    "block": block,
                    "inverse": inverse,
                }
                steps.append(
                    _frame(
                        light,
                        exposure,
                        pattern,
                        {**tags, "role": "gray", "axis": axis, "bit": bit, "inverse": inverse},
                    )
                )
        for s in range(steps_count):
            shift = s * period / steps_count
            if shift != int(shift):
                raise ProcedureError(
                    step_error(
                        "sweep.phase_steps",
                        f"{steps_count} steps do not divide the period {period} px"
                        " into whole pixels",
                        "choose a period that is a multiple of phase_steps",
                    )
                )
            pattern = {"kind": "periodic", "axis": axis, "profile": profile, "shift": int(shift)}
            steps.append(
                _frame(light, exposure, pattern, {**tags, "role": "phase", "axis": axis, "step": s})
            )
    return steps


def _line_steps(
    light: str, exposure: float, tags: dict, slm_shape: tuple[int, int], sweep: Mapping
) -> list[Step]:
    stride = int(sweep.get("line_stride_px", 8))
    spacing = int(sweep.get("line_spacing_px", 64))
    steps = []
    for axis, length in (("x", slm_shape[1]), ("y", slm_shape[0])):
        for offset in range(0, min(spacing, length), stride):
            pattern = {
                "kind": "lines",
                "axis": axis,
                "offset": offset,
                "spacing": spacing,
                "width": 1,
            }
            steps.append(
                _frame(
                    light,
                    exposure,
                    pattern,
                    {**tags, "role": "line", "axis": axis, "offset": offset},
                )
            )
    return steps


def sweep_plan(
    procedure: Mapping[str, Any],
    slm_shape: tuple[int, int],
    exposures: Mapping[float, float],
    profile: list[int] | None,
    blur_exposures: Mapping[float, float] | None = None,
) -> Plan:
    """The laser-by-laser sweep plan.

    Parameters
    ----------
    procedure
        The validated spectral-calibration procedure.
    slm_shape
        SLM (height, width).
    exposures
        Exposure (s) per laser line used by the sweep.
    profile
        Grey levels of one sinusoid period, precompensated for the SLM's response
        (structured mode; ignored in line mode).
    blur_exposures
        Exposure per line for the pinhole (blur) frames; lines only in this mapping
        (e.g. an extra 405 nm line) get pinhole frames but no sweep.

    Returns
    -------
    Plan
        ``spectral-sweep``: per line, its dark, blank and full frames and its sweep (Gray
        code and phase, or lines), then its pinhole (blur) frames; each step is tagged
        with its role and laser.

    Examples
    --------
    >>> from sassi_bench.acquire.plan_geometry import planned_spectral
    >>> from sassi_bench.procedure import load_procedure
    >>> from sassi_bench.rig.config import load_rig_description
    >>> proc = planned_spectral(load_procedure("spectral_calibration"), load_rig_description("sim"))
    >>> plan = sweep_plan(proc, (400, 640), {532.0: 0.05}, list(range(0, 256, 16)))
    >>> len(plan.select(role="gray", laser=532.0)), len(plan.select(role="phase"))
    (26, 16)
    """
    sweep = procedure["sweep"]
    blur = procedure["blur"]
    unplanned = [
        f"{section}.{key}"
        for section, key in (("sweep", "phase_period_px"), ("sweep", "gray_block_px"),
                             ("blur", "pinhole_pitch_px"))
        if procedure[section].get(key, 0) is None
    ]  # fmt: skip
    if unplanned:
        raise ProcedureError(
            step_error(
                "sweep plan",
                f"the procedure leaves {', '.join(unplanned)} to be derived from the rig",
                "pass the procedure through "
                "sassi_bench.acquire.plan_geometry.planned_spectral(procedure, rig.description)",
            )
        )
    blur_exposures = dict(blur_exposures or exposures)
    pattern = blur_pinholes(blur.get("pinhole_pitch_px", [40, 40]), slm_shape)
    lines = sorted(set(exposures) | set(blur_exposures))
    steps: list[Step] = []
    for laser in lines:
        light = laser_light(laser)
        tags = {"laser": float(laser)}
        if laser in exposures:
            exposure = float(exposures[laser])
            steps.append(_frame("off", exposure, {"kind": "blank"}, {**tags, "role": "dark"}))
            steps.append(_frame(light, exposure, {"kind": "blank"}, {**tags, "role": "blank"}))
            steps.append(_frame(light, exposure, {"kind": "full"}, {**tags, "role": "full"}))
            if sweep["mode"] == "structured":
                steps += _structured_steps(light, exposure, tags, slm_shape, sweep, profile)
            else:
                steps += _line_steps(light, exposure, tags, slm_shape, sweep)
        exposure = float(blur_exposures[laser])
        steps.append(_frame(light, exposure, {"kind": "blank"}, {**tags, "role": "blur-blank"}))
        for frame in range(int(blur.get("frames", 2))):
            steps.append(
                _frame(light, exposure, pattern, {**tags, "role": "pinholes", "frame": frame})
            )
    parameters = {
        "scene": "white",
        "procedure": {k: v for k, v in procedure.items() if k != "source"},
        "mode": sweep["mode"],
        "exposures_s": {f"{k:g}": float(v) for k, v in exposures.items()},
        "blur_exposures_s": {f"{k:g}": float(v) for k, v in blur_exposures.items()},
        "profile": profile,
    }
    return Plan("spectral-sweep", tuple(steps), parameters)


def blur_plan(sweep: Plan, first: int, budget: int) -> Plan:
    """More pinhole frames of every laser, as the sweep showed them (pattern, light and
    exposure): frames ``first`` to ``budget - 1`` (the sweep holds the first ``first``).

    Parameters
    ----------
    sweep
        The sweep session's plan (:func:`sweep_plan`).
    first, budget
        Pinhole frames per laser the sweep took (``blur.frames``), and the most the blur
        step may take (``blur.max_frames``).

    Returns
    -------
    Plan
        ``spectral-blur``: steps tagged ``role: pinholes`` with their ``laser`` and
        ``frame``, frame by frame (every laser's next frame before any laser's after it).

    Examples
    --------
    >>> from sassi_bench.acquire.plan_geometry import planned_spectral
    >>> from sassi_bench.procedure import load_procedure
    >>> from sassi_bench.rig.config import load_rig_description
    >>> proc = planned_spectral(load_procedure("spectral_calibration"), load_rig_description("sim"))
    >>> sweep = sweep_plan(proc, (400, 640), {532.0: 0.05, 635.0: 0.04}, list(range(0, 256, 16)))
    >>> plan = blur_plan(sweep, 2, 5)
    >>> len(plan), sorted({s.tags["frame"] for s in plan.steps})
    (6, [2, 3, 4])
    """
    shown = {}
    for step in sweep.steps:
        if step.tags.get("role") == "pinholes":
            shown.setdefault(float(step.tags["laser"]), step)
    steps = [
        replace(step, tags={**step.tags, "frame": frame})
        for frame in range(first, budget)
        for step in shown.values()
    ]
    return Plan("spectral-blur", tuple(steps), {"scene": "white", "sweep_frames": first})


def blur_pinholes(pitch: Sequence[int], slm_shape: tuple[int, int]) -> dict[str, Any]:
    """The blur frames' pinhole pattern: a grid at least ``pitch`` apart whose first and
    last pinholes sit on the SLM's edges, so a fit over the field interpolates between
    spots everywhere instead of extrapolating past the outermost ones.

    On each axis the grid keeps as many pinholes as ``pitch`` fits between the edges and
    spreads them (whole SLM px) to reach both; the spare pixels split between the ends.

    Parameters
    ----------
    pitch
        The least (horizontal, vertical) spacing, SLM px (``blur.pinhole_pitch_px``).
    slm_shape
        SLM (height, width).

    Returns
    -------
    dict
        A ``pinholes`` pattern descriptor.

    Examples
    --------
    >>> blur_pinholes([40, 40], (200, 320))
    {'kind': 'pinholes', 'pitch': [45, 49], 'offset': [2, 1]}
    """
    spread, offset = [], []
    for step, size in zip((int(p) for p in pitch), (slm_shape[1], slm_shape[0]), strict=True):
        gaps = (size - 1) // step
        if gaps == 0:  # room for one pinhole only: the middle
            spread.append(size)
            offset.append(size // 2)
            continue
        wider = (size - 1) // gaps
        spread.append(wider)
        offset.append((size - 1 - wider * gaps) // 2)
    return {"kind": "pinholes", "pitch": spread, "offset": offset}


def lamp_pinholes(procedure: Mapping[str, Any]) -> dict[str, Any]:
    """The pinhole pattern of the lamp frames (``lamps.pinhole_pitch_px``).

    Examples
    --------
    >>> lamp_pinholes({"lamps": {"pinhole_pitch_px": [100, 24]}})
    {'kind': 'pinholes', 'pitch': [100, 24], 'offset': [50, 12]}
    """
    lamps = procedure.get("lamps") or {}
    pitch = [int(p) for p in lamps.get("pinhole_pitch_px") or LAMP_PINHOLE_PITCH_PX]
    return {"kind": "pinholes", "pitch": pitch, "offset": [pitch[0] // 2, pitch[1] // 2]}


#: A lamp line the field blur is measured at, past the lasers' band: at least this share of
#: its lamp's strongest line (the table's typical intensities; only to choose lines) ...
BLUR_LINE_MIN_INTENSITY = 0.1
#: ... with no line of at least this share of its own light within
#: :data:`BLUR_LINE_CLEAR_NM` (weaker neighbours are fitted beside it:
#: :func:`~sassi_bench.calibrate.line_spots.measure_line_spots`) ...
BLUR_LINE_NEIGHBOUR_SHARE = 0.25
BLUR_LINE_CLEAR_NM = 15.0
#: ... and at least this far (nm) outside the lasers' band (the lasers measure inside it).
BLUR_LINE_MARGIN_NM = 5.0
#: The lamp field frames: the lamp pinhole grid at this many offsets over one pitch on
#: both axes (:func:`lamp_field_pinholes`), so the lines' spots reach the whole field, each
#: taken in batches until the field blur's stated widths meet their tolerance: a dim blue
#: line's spot widths are photon-limited
#: (``docs/notes/2026-11-30-design-rig-blue-blur-and-scan-pitch.md``).
LAMP_FIELD_OFFSETS = 4


def blur_lamp_lines(lines: LineList, lasers_nm: Sequence[float], desc: RigDescription):
    """The lamp's lines a field blur is measured at beyond the lasers' band: strong, clear
    of comparable lines, on the rig's spectral grid and outside the lasers' band.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> desc = load_rig_description("sim-singlet")
    >>> lasers = (450, 520, 532, 635, 670)
    >>> [blur_lamp_lines(t, lasers, desc).tolist() for t in desc.lamp_lines().values()]
    [[404.6565, 435.8335], []]
    """
    lam, power = lines.wavelengths_nm, lines.relative_intensity
    grid = desc.spectral_grid
    strong = power >= BLUR_LINE_MIN_INTENSITY * power.max()
    comparable = power[None, :] >= BLUR_LINE_NEIGHBOUR_SHARE * power[:, None]
    close = np.abs(lam[:, None] - lam[None, :]) < BLUR_LINE_CLEAR_NM
    clear = ~(comparable & close & ~np.eye(lam.size, dtype=bool)).any(axis=1)
    low, high = min(lasers_nm), max(lasers_nm)
    outside = (lam < low - BLUR_LINE_MARGIN_NM) | (lam > high + BLUR_LINE_MARGIN_NM)
    on_grid = (lam >= grid.start_nm) & (lam <= grid.stop_nm)
    return lam[strong & clear & outside & on_grid]


def lamp_field_pinholes(
    pattern: Mapping[str, Any], slm_shape: tuple[int, int] | None = None
) -> list[dict[str, Any]]:
    """The lamp field frames' patterns: the lamp pinhole grid at :data:`LAMP_FIELD_OFFSETS`
    offsets over one pitch on both axes, the first at the SLM's top-left corner and,
    given the SLM's shape, the last putting pinholes on its right and bottom edges, so
    the lamp lines' spots reach the whole field (the others spread evenly between).

    Examples
    --------
    >>> [p["offset"] for p in lamp_field_pinholes({"kind": "pinholes", "pitch": [155, 27]})]
    [[0, 0], [39, 7], [78, 14], [116, 20]]
    >>> pattern = {"kind": "pinholes", "pitch": [155, 27]}
    >>> [p["offset"] for p in lamp_field_pinholes(pattern, (200, 320))]  # 319 = 9 + 2 * 155
    [[0, 0], [52, 9], [103, 18], [9, 10]]
    """
    pitch = [int(p) for p in pattern["pitch"]]
    count = LAMP_FIELD_OFFSETS
    if slm_shape is None:
        offsets = [[round(j * p / count) for p in pitch] for j in range(count)]
    else:
        height, width = slm_shape
        offsets = [[round(j * p / (count - 1)) for p in pitch] for j in range(count - 1)]
        offsets.append([(width - 1) % pitch[0], (height - 1) % pitch[1]])
    return [{"kind": "pinholes", "pitch": pitch, "offset": offset} for offset in offsets]


def lamp_plan(
    procedure: Mapping[str, Any],
    exposures: Mapping[str, float],
    frames: int | None = None,
    field_lamps: Sequence[str] = (),
    slm_shape: tuple[int, int] | None = None,
) -> Plan:
    """Pinhole frames under each wavelength lamp, with as many closed-SLM frames.

    A step that measures until confident plans its budget and captures the first frames
    of every lamp (their ``frame`` tag), then decides whether to go on.

    Parameters
    ----------
    procedure
        The validated spectral-calibration procedure (``lamps.pinhole_pitch_px``,
        ``lamps.frames``).
    exposures
        Exposure (s) per lamp light (``"lamp:HgAr"``).
    frames
        Pinhole frames per lamp planned (None: ``lamps.frames``).
    field_lamps
        Lamps (light names) whose lines measure a field blur past the lasers' band
        (:func:`blur_lamp_lines`): they also get ``role: lamp-field`` frames, the pinhole
        grid at every offset of :func:`lamp_field_pinholes`, ``frames`` times each (tagged
        ``offset`` and ``frame`` 0, 1, ...; the lamp field step takes them in batches).
    slm_shape
        SLM (height, width): the lamp field frames reach its right and bottom edges.

    Returns
    -------
    Plan
        Steps tagged ``role: lamp-blank`` and ``role: lamp-pinholes`` (and
        ``lamp-field``) with their ``lamp`` (light name) and ``frame``.

    Examples
    --------
    >>> from sassi_bench.procedure import load_procedure
    >>> plan = lamp_plan(load_procedure("spectral_calibration"), {"lamp:HgAr": 0.05})
    >>> len(plan), len(plan.select(role="lamp-pinholes", lamp="lamp:HgAr"))
    (8, 4)
    >>> [s.tags["frame"] for s in lamp_plan({}, {"lamp:HgAr": 0.05}, frames=2).steps]
    [0, 1, 0, 1]
    """
    first = int((procedure.get("lamps") or {}).get("frames", 4))
    if frames is None:
        frames = first
    pattern = lamp_pinholes(procedure)
    steps = []
    for light, exposure in exposures.items():
        for role, shown in (("lamp-blank", {"kind": "blank"}), ("lamp-pinholes", pattern)):
            for frame in range(frames):
                tags = {"lamp": light, "role": role, "frame": frame}
                steps.append(_frame(light, exposure, shown, tags))
        if light in field_lamps:
            for offset, shown in enumerate(lamp_field_pinholes(pattern, slm_shape)):
                for frame in range(frames):
                    tags = {"lamp": light, "role": "lamp-field", "frame": frame, "offset": offset}
                    steps.append(_frame(light, exposure, shown, tags))
    parameters = {
        "scene": "white",
        "procedure": {k: v for k, v in procedure.items() if k != "source"},
        "exposures_s": {light: float(t) for light, t in exposures.items()},
        "pinholes": pattern,
    }
    return Plan("spectral-lamps", tuple(steps), parameters)


def lamp_band(lines: LineList, desc: RigDescription) -> tuple[float, float]:
    """The span (nm) of a lamp's lines that its streaks are cut for: those on the rig's
    spectral grid.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> desc = load_rig_description("sim")
    >>> lamp_band(desc.lamp_lines()["HgAr"], desc)
    (404.6565, 706.7218)
    """
    grid = desc.spectral_grid
    inside = (lines.wavelengths_nm >= grid.start_nm) & (lines.wavelengths_nm <= grid.stop_nm)
    lam = lines.wavelengths_nm[inside]
    return float(lam.min()), float(lam.max())


def check_lamp_pitch(desc: RigDescription, procedure: Mapping[str, Any]) -> None:
    """Refuse a lamp pinhole pitch at which one pinhole's lines reach the next pinhole's.

    Judged by the description's nominal optics (a ray trace) and described blur, on a grid
    of field points: each streak from 4 spot sigmas and 1 camera px before the first lamp
    line to as far after the last, and one SLM pixel's step of free columns between
    neighbouring streaks (:func:`~sassi_bench.acquire.streak_pitch.pitch_room`). A
    procedure that leaves the pitch ``null`` gets the smallest that passes
    (:func:`~sassi_bench.acquire.plan_geometry.plan_geometry`).

    Raises
    ------
    ConfigError
        Naming the smallest pitch that keeps the streaks apart.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> check_lamp_pitch(load_rig_description("sim"), {"lamps": {"pinhole_pitch_px": [100, 24]}})
    >>> check_lamp_pitch(load_rig_description("sim"), {"lamps": {"pinhole_pitch_px": [60, 24]}})
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: lamp frames: ... Fix: set lamps.pinhole_pitch_px to at ...
    """
    lines = desc.lamp_lines()
    if not lines:
        return
    low = min(lamp_band(x, desc)[0] for x in lines.values())
    high = max(lamp_band(x, desc)[1] for x in lines.values())
    pitch = [int(p) for p in lamp_pinholes(procedure)["pitch"]]
    room = pitch_room(desc, pitch[0], (low, high), LAMP_REACH_SIGMAS, LAMP_MARGIN_PX)
    if pitch[0] < room.needed_pitch:
        raise ConfigError(
            step_error(
                "lamp frames",
                f"a {pitch[0]} SLM px pinhole pitch puts the lamp streaks into each other (each "
                f"spans {room.footprint_px:.0f} camera px from {low:.1f} to {high:.1f} nm with "
                f"{LAMP_REACH_SIGMAS:g} sigma of blur, neighbouring pinholes are "
                f"{room.distance_px:.0f} camera px apart)",
                f"set lamps.pinhole_pitch_px to at least [{room.needed_pitch}, {pitch[1]}], or "
                "to null (derived from the rig's optics)",
            )
        )
