"""A real bench's devices opened one at a time, for ``sassi-bench rig check``.

:func:`~sassi_bench.rig.hardware.build.build_hardware_rig` opens the whole rig and stops
at the first device that does not open; here each device is opened on its own and a
failure becomes a :class:`~sassi_bench.rig.device_check.Finding` with its fix (the port,
the extra to install, the ``.cti``, the display), so a lab learns about every device in
one run. The opened devices are then checked against the description
(:func:`~sassi_bench.rig.device_check.check_devices`) and closed.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Any

from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.device_check import (
    Finding,
    RigCheckReport,
    check_devices,
    finding_from_error,
)

__all__ = ["check_hardware_rig", "open_one_by_one"]

#: How long the trigger counts the SLM's pulses on a real bench.
PULSE_WAIT_S = 0.5


def open_one_by_one(
    desc: RigDescription,
) -> tuple[dict[str, Any], list[Finding]]:
    """Open every device of a ``backend: hardware`` rig in turn.

    Returns
    -------
    devices
        The opened handles by key; ``None`` where a device did not open.
    findings
        One finding per device: what opened, or why not and the fix.
    """
    from sassi_bench.rig.hardware.build import open_camera
    from sassi_bench.rig.hardware.manual import ManualLight
    from sassi_bench.rig.hardware.slm_display import DisplaySlm
    from sassi_bench.rig.hardware.trigger import ArduinoTrigger

    hw = desc.hardware or {}
    devices: dict[str, Any] = {}
    findings: list[Finding] = []

    def attempt(key: str, label: str, opener: Callable[[], Any], say: Callable[[Any], str]) -> None:
        try:
            device = opener()
        except Exception as exc:  # every device is tried, whatever the last one did
            devices[key] = None
            findings.append(finding_from_error(label, exc))
            return
        devices[key] = device
        findings.append(Finding(label, "ok", say(device)))

    trigger_spec = dict(hw.get("trigger", {}))
    port = trigger_spec.pop("port", "")
    trigger_spec.pop("kind", None)
    attempt(
        "trigger",
        "trigger",
        lambda: ArduinoTrigger(port, **trigger_spec),
        lambda t: f"{t.identity} on {t.port}",
    )
    monitor = hw.get("slm", {}).get("monitor", 1)
    attempt(
        "slm",
        "SLM",
        lambda: DisplaySlm((desc.slm.height, desc.slm.width), monitor=monitor),
        lambda s: (
            f"window on monitor {s.monitor.name} {s.monitor.width}x{s.monitor.height} "
            f"at ({s.monitor.x}, {s.monitor.y})"
        ),
    )

    def state() -> tuple[int | None, str]:
        slm = devices.get("slm")
        return (None if slm is None else slm.pattern_id), "unknown"

    for key, label in (("spectral_camera", "spectral camera"), ("guide_camera", "guide camera")):
        spec = hw.get(key, {})
        attempt(
            key,
            label,
            lambda key=key, spec=spec: open_camera(key.split("_")[0], spec, state),
            lambda c, spec=spec: (
                f"{spec.get('kind')} camera, "
                + "x".join(str(s) for s in c.shape[1::-1])
                + f" {c.bit_depth}-bit, trigger {getattr(c, 'trigger', '?')}"
            ),
        )
    attempt(
        "light",
        "lights",
        lambda: ManualLight(desc.lasers_nm, desc.wavelength_lamps, prompt=_no_prompt),
        lambda light: f"switched by the operator when asked: {', '.join(light.available)}",
    )
    return devices, findings


def _no_prompt(message: str) -> None:
    """A rig check switches no light."""


def close_devices(devices: dict[str, Any]) -> None:
    """Close every opened device (cameras first, the trigger last)."""
    for key in ("guide_camera", "spectral_camera", "slm", "trigger"):
        device = devices.get(key)
        close = getattr(device, "close", None)
        if close is not None:
            with contextlib.suppress(Exception):
                close()


def check_hardware_rig(desc: RigDescription, pulse_wait_s: float = PULSE_WAIT_S) -> RigCheckReport:
    """Open each device of a real bench in turn, check it and close it again.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        from sassi_bench.rig.config import load_rig_description
        report = check_hardware_rig(load_rig_description("lab-example"))
        report.failed_devices()
        # ['trigger', 'SLM', 'spectral camera', 'guide camera']
    """
    devices, opened = open_one_by_one(desc)
    try:
        return check_devices(desc, devices, opened, pulse_wait_s=pulse_wait_s)
    finally:
        close_devices(devices)
