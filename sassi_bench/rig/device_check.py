"""A rig's devices checked one by one against its description: ``sassi-bench rig check``.

Each device is looked at in turn and every finding is a :class:`Finding` (ok, warn or
fail, with the fix); a device that fails does not stop the others. What is checked is the
same on every backend, through the device protocols only:

- the SLM: its size against ``slm.width`` x ``slm.height``, one pattern shown and read
  back;
- the trigger: armed at divider 1 while patterns are shown, its pulse counters read
  (pulses received from the SLM, passed to the cameras);
- each camera: frame size and bit depth against the rig's camera section, its exposure
  range against the rig's, one test frame with the SLM closed (the dark level against
  ``dark_offset_adu``, the share of saturated pixels);

Opening the devices is the backend's part (:mod:`sassi_bench.rig.hardware.check` opens a
real bench's one at a time, so a missing one is a finding, not an exception).

Examples
--------
>>> from sassi_bench.rig import open_rig
>>> rig = open_rig("sim")
>>> report = check_devices(rig.description, devices_of(rig), opened=virtual_findings(rig))
>>> report.ok
True
>>> print(report.findings[2].line())
  ok    SLM              virtual SLM 640x400
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sassi_bench.errors import SassiBenchError
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.protocols import Camera, LightSource, Slm, Trigger
from sassi_bench.rig.rig import Rig

__all__ = [
    "DEVICES",
    "Finding",
    "RigCheckReport",
    "check_devices",
    "devices_of",
    "finding_from_error",
    "virtual_findings",
]

#: The devices of a rig, in the order they are checked: (key, label).
DEVICES = (
    ("trigger", "trigger"),
    ("slm", "SLM"),
    ("spectral_camera", "spectral camera"),
    ("guide_camera", "guide camera"),
    ("light", "lights"),
)
_LABELS = dict(DEVICES)

#: A test frame with more than this share of pixels at full scale is reported.
SATURATED_WARN = 1e-3


@dataclass(frozen=True)
class Finding:
    """One thing found about one device.

    Parameters
    ----------
    device
        The device's label (``"spectral camera"``).
    status
        ``"ok"``, ``"warn"`` or ``"fail"``.
    text
        What was found or measured.
    fix
        What to do about a warning or failure.

    Examples
    --------
    >>> print(Finding("trigger", "fail", "no answer", "flash the firmware").line())
      FAIL  trigger          no answer. Fix: flash the firmware
    """

    device: str
    status: str
    text: str
    fix: str = ""

    def line(self) -> str:
        """The finding as one printed line."""
        mark = {"ok": "ok  ", "warn": "WARN", "fail": "FAIL"}[self.status]
        fix = f". Fix: {self.fix}" if self.fix else ""
        return f"  {mark}  {self.device:16s} {self.text}{fix}"


@dataclass
class RigCheckReport:
    """Every finding of a rig check, in device order, and how long it took."""

    rig: str
    findings: list[Finding] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        """No finding failed."""
        return not any(f.status == "fail" for f in self.findings)

    def failed_devices(self) -> list[str]:
        """Labels of the devices with a failed finding, in order."""
        return list(dict.fromkeys(f.device for f in self.findings if f.status == "fail"))

    def lines(self) -> list[str]:
        """The findings as printed lines."""
        return [f.line() for f in self.findings]


def finding_from_error(device: str, error: BaseException) -> Finding:
    """A failed finding from a workbench error (its cause and fix split apart) or any
    other exception (named, with a generic fix).

    Examples
    --------
    >>> from sassi_bench.errors import DeviceError
    >>> f = finding_from_error("trigger", DeviceError("trigger connect: no answer. Fix: flash it"))
    >>> f.text, f.fix
    ('trigger connect: no answer', 'flash it')
    """
    message = " ".join(str(error).split()) or type(error).__name__
    if isinstance(error, SassiBenchError) and ". Fix: " in message:
        cause, fix = message.split(". Fix: ", 1)
        return Finding(device, "fail", cause, fix)
    return Finding(
        device,
        "fail",
        f"{type(error).__name__}: {message}",
        "see docs/real_bench.md (section 6, errors you may meet)",
    )


def devices_of(rig: Rig) -> dict[str, Any]:
    """A rig's device handles by key (:data:`DEVICES`)."""
    return {key: getattr(rig, key) for key, _ in DEVICES}


def virtual_findings(rig: Rig) -> list[Finding]:
    """What a rig opened as a whole reports on opening: one line per device, the kind
    of each (``SimSlm`` and the like for the virtual bench)."""
    shown = []
    for key, label in DEVICES:
        device = getattr(rig, key)
        what = _describe(device)
        if key in rig.simulated_by:
            what += f" (simulated: {rig.simulated_by[key]})"
        shown.append(Finding(label, "ok", what))
    return shown


def _describe(device: Any) -> str:
    """A short description of an opened device."""
    if isinstance(device, Slm):
        height, width = device.shape
        monitor = getattr(device, "monitor", None)
        where = (
            "" if monitor is None else f" on monitor {monitor.name} at ({monitor.x}, {monitor.y})"
        )
        kind = "virtual SLM" if type(device).__name__.startswith("Sim") else "SLM window"
        return f"{kind} {width}x{height}{where}"
    if isinstance(device, Camera):
        shape = "x".join(str(s) for s in device.shape[1::-1])
        channels = " RGB" if len(device.shape) == 3 else ""
        return f"{type(device).__name__} {shape}{channels} {device.bit_depth}-bit"
    if isinstance(device, Trigger):
        identity = getattr(device, "identity", "")
        port = getattr(device, "port", "")
        if identity:
            return f"{identity} on {port}"
        return f"{type(device).__name__}"
    if isinstance(device, LightSource):
        if getattr(device, "by_hand", False):
            return f"switched by the operator when asked: {', '.join(device.available)}"
        return f"{type(device).__name__}: {', '.join(device.available)}"
    return type(device).__name__


def check_devices(
    desc: RigDescription,
    devices: dict[str, Any],
    opened: Iterable[Finding] = (),
    *,
    pulse_wait_s: float = 0.0,
    clock: Callable[[], float] = time.monotonic,
) -> RigCheckReport:
    """Check the opened devices of a rig against its description.

    Parameters
    ----------
    desc
        The rig description.
    devices
        Device handles by key (:data:`DEVICES`); ``None`` for one that did not open.
    opened
        The findings of opening the devices (one per device, in order).
    pulse_wait_s
        How long the trigger counts pulses while patterns are shown (a real SLM pulses
        with its refresh: 0.5 s counts about 30; the virtual one pulses per pattern).
    clock
        Seconds, for the report's duration.

    Returns
    -------
    RigCheckReport
        The opening findings, then the checks of each device, grouped by device.
    """
    start = clock()
    found: dict[str, list[Finding]] = {label: [] for _, label in DEVICES}
    for finding in opened:
        found.setdefault(finding.device, []).append(finding)

    def guarded(key: str, check: Callable[[], list[Finding]]) -> None:
        label = _LABELS[key]
        if devices.get(key) is None:
            return
        try:
            found[label].extend(check())
        except Exception as exc:  # a device fault must not stop the other checks
            found[label].append(finding_from_error(label, exc))

    slm, trigger = devices.get("slm"), devices.get("trigger")
    guarded("slm", lambda: _check_slm(slm, desc))
    guarded("trigger", lambda: _check_trigger(trigger, slm, pulse_wait_s))
    armed = False
    if trigger is not None:
        with contextlib.suppress(Exception):  # its own finding already says why
            trigger.set_divider(1)
            trigger.arm()
            armed = True
    try:
        if slm is not None:
            with contextlib.suppress(Exception):
                slm.show(np.zeros(slm.shape, np.uint8))
        for key, described in (
            ("spectral_camera", desc.spectral_camera),
            ("guide_camera", desc.guide_camera),
        ):
            camera = devices.get(key)
            guarded(key, lambda camera=camera, described=described, key=key: _check_camera(
                camera, described, _LABELS[key], triggered=armed
            ))  # fmt: skip
    finally:
        if armed:
            with contextlib.suppress(Exception):
                trigger.disarm()
    findings = [f for _, label in DEVICES for f in found[label]]
    return RigCheckReport(desc.name, findings, clock() - start)


def _check_slm(slm: Slm, desc: RigDescription) -> list[Finding]:
    described = (desc.slm.height, desc.slm.width)
    out = []
    if tuple(slm.shape) != described:
        out.append(
            Finding(
                "SLM",
                "fail",
                f"{slm.shape[1]}x{slm.shape[0]}, the rig says {described[1]}x{described[0]}",
                "set slm.width and slm.height in the rig YAML to the SLM's native mode",
            )
        )
    pattern = np.zeros(slm.shape, np.uint8)
    pattern[::2, ::2] = 255  # a pattern no blank or stale screen matches
    shown = slm.show(pattern)
    if not np.array_equal(slm.current_pattern(), pattern):
        out.append(Finding("SLM", "fail", f"pattern {shown} does not read back", ""))
    else:
        out.append(Finding("SLM", "ok", f"test pattern shown (pattern id {shown})"))
    return out


def _check_trigger(trigger: Trigger, slm: Slm | None, wait_s: float) -> list[Finding]:
    reset = getattr(trigger, "reset_counters", None)
    if reset is not None:
        reset()
    trigger.set_divider(1)
    before = trigger.counters()
    trigger.arm()
    try:
        if slm is not None:
            for level in (0, 255, 0):
                slm.show(np.full(slm.shape, level, np.uint8))
        time.sleep(wait_s)
        after = trigger.counters()
    finally:
        trigger.disarm()
    received = after["received"] - before["received"]
    passed = after["passed"] - before["passed"]
    counted = f"{received} SLM pulses received, {passed} passed to the cameras"
    if received == 0:
        return [
            Finding(
                "trigger",
                "fail",
                f"armed, but {counted}" + ("" if slm is not None else " (the SLM did not open)"),
                "connect the SLM driver's sync output to the Arduino's D2 and their grounds "
                "(docs/real_bench.md, wiring)",
            )
        ]
    if passed == 0:
        return [
            Finding(
                "trigger",
                "fail",
                f"armed at divider 1, but {counted}",
                "flash the trigger firmware again (make -C procedures/firmware upload)",
            )
        ]
    return [Finding("trigger", "ok", f"armed at divider 1: {counted}")]


def _check_camera(camera: Camera, described: Any, label: str, *, triggered: bool) -> list[Finding]:
    out = []
    section = "spectral_camera" if label.startswith("spectral") else "guide_camera"
    size = (described.height, described.width)
    if tuple(camera.shape[:2]) != size:
        out.append(
            Finding(
                label,
                "fail",
                f"frames are {camera.shape[1]}x{camera.shape[0]}, the rig says {size[1]}x{size[0]}",
                f"set {section}.width and height to the camera's frame (or its ROI and "
                "binning to the rig's)",
            )
        )
    if camera.bit_depth != described.bit_depth:
        out.append(
            Finding(
                label,
                "warn",
                f"{camera.bit_depth}-bit frames, the rig says {described.bit_depth}",
                f"set {section}.bit_depth: {camera.bit_depth} (or the camera's pixel format "
                f"to {described.bit_depth} bits)",
            )
        )
    lo, hi = camera.exposure_range_s
    want_lo, want_hi = described.exposure_range_s
    if want_lo < lo or want_hi > hi:
        out.append(
            Finding(
                label,
                "warn",
                f"exposure {lo:g}..{hi:g} s, the rig allows {want_lo:g}..{want_hi:g} s",
                f"set {section}.exposure_range_s inside [{lo:g}, {hi:g}]",
            )
        )
    else:
        out.append(Finding(label, "ok", f"exposure {lo:g}..{hi:g} s covers the rig's"))
    out.append(_test_frame(camera, described, label, triggered))
    return out


def _test_frame(camera: Camera, described: Any, label: str, triggered: bool) -> Finding:
    """One frame with the SLM closed: its dark level and saturated share."""
    try:
        frame = camera.capture()
    except SassiBenchError as exc:
        finding = finding_from_error(label, exc)
        if not triggered:
            return Finding(label, "fail", f"{finding.text} (the trigger is not armed)", finding.fix)
        return finding
    data = frame.data
    full = (1 << camera.bit_depth) - 1
    saturated = float(np.count_nonzero(data >= full)) / data.size
    level = float(np.median(data))
    offset = getattr(described, "dark_offset_adu", None)
    said = "" if offset is None else f" (the rig says {offset:g})"
    text = (
        f"test frame at {camera.exposure_s:g} s, SLM closed: dark level {level:.1f} ADU{said}, "
        f"{100 * saturated:.2f} % saturated"
    )
    if saturated > SATURATED_WARN:
        return Finding(
            label, "warn", text, "shorten the exposure, dim the light or close the aperture"
        )
    return Finding(label, "ok", text)
