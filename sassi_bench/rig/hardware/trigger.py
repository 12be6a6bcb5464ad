"""Serial driver for the exposure-trigger firmware (``procedures/firmware/trigger.c``).

An Arduino Uno between the SLM's master pulse and the cameras passes every n-th
pulse while armed and counts them. The host talks to it over a line protocol: every
command gets one reply line; ``ERR ...`` replies, a missing port and a silent device
raise a :class:`~sassi_bench.errors.DeviceError` that names the step, the cause and
the fix. A dropped connection is reopened once and the divider and armed state are
sent again; so is the state after the device reports a reset (``READY ...``).
"""

from __future__ import annotations

import contextlib
import time
import warnings
from collections.abc import Callable
from typing import Any

import serial

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.base import TriggerBase

__all__ = ["FIRMWARE_ID", "ArduinoTrigger"]

FIRMWARE_ID = "SASSI-TRIGGER 1"

_PORT_FIX = (
    "plug the Arduino in and set hardware.trigger.port in the rig YAML to its port "
    "(list them with `ls /dev/serial/by-id/ /dev/ttyACM* /dev/ttyUSB*`); on Linux the "
    "user must be in the dialout group"
)
_SILENT_FIX = (
    "flash the trigger firmware (`make -C procedures/firmware upload PORT=<port>`), "
    "check the cable and that hardware.trigger.baudrate is 115200"
)


class ArduinoTrigger(TriggerBase):
    """The exposure gate on an Arduino Uno running the SASSI trigger firmware.

    Parameters
    ----------
    port
        Serial port (``/dev/ttyACM0``, a ``/dev/serial/by-id/...`` link, ``COM3``).
    baudrate
        Line speed; the firmware uses 115200.
    timeout_s
        How long to wait for one reply line.
    boot_s
        How long the device may take to answer after the port opens (an Uno resets
        when the port opens and its bootloader waits about a second).
    serial_factory
        Opens the port; defaults to :class:`serial.Serial` (tests pass their own).

    Raises
    ------
    DeviceError
        If the port cannot be opened, the device stays silent for ``boot_s`` or it
        is not running the trigger firmware.

    Examples
    --------
    Not run here (it needs the hardware)::

        trigger = ArduinoTrigger("/dev/ttyACM0")
        trigger.set_divider(2); trigger.arm()
        trigger.counters()
        # {'received': 0, 'passed': 0}
    """

    def __init__(
        self,
        port: str,
        *,
        baudrate: int = 115200,
        timeout_s: float = 1.0,
        boot_s: float = 3.0,
        serial_factory: Callable[..., Any] | None = None,
    ) -> None:
        super().__init__()
        self.port = str(port)
        self.baudrate = int(baudrate)
        self.timeout_s = float(timeout_s)
        self.boot_s = float(boot_s)
        self._factory = serial_factory or serial.Serial
        self._serial: Any = None
        self.identity = ""
        self.resets = 0
        self._connect()

    # -- connection -------------------------------------------------------------

    def _open(self) -> None:
        try:
            self._serial = self._factory(
                self.port, self.baudrate, timeout=self.timeout_s, write_timeout=self.timeout_s
            )
        except (serial.SerialException, OSError) as exc:
            raise DeviceError(
                step_error(
                    "trigger connect", f"cannot open serial port {self.port!r} ({exc})", _PORT_FIX
                )
            ) from exc

    def _connect(self) -> None:
        """Open the port, wait for the firmware to answer and push the host's state."""
        self._open()
        deadline = time.monotonic() + self.boot_s
        reply = other = ""
        self._serial.reset_input_buffer()
        while not reply and time.monotonic() < deadline:
            self._write("ID?")
            line = self._read_line(min(self.timeout_s, max(deadline - time.monotonic(), 0.05)))
            # Skip boot banners, bootloader noise and lines cut by the buffer reset.
            while line and not line.startswith(FIRMWARE_ID):
                other = line
                line = self._read_line(min(self.timeout_s, 0.2))
            reply = line
        if not reply:
            self.close()
            if other:
                raise DeviceError(
                    step_error(
                        "trigger connect",
                        f"the device on {self.port!r} answered {other!r}, not {FIRMWARE_ID!r}",
                        "check the port is the trigger Arduino's and flash the trigger "
                        "firmware (`make -C procedures/firmware upload PORT=<port>`)",
                    )
                )
            raise DeviceError(
                step_error(
                    "trigger connect",
                    f"no answer from {self.port!r} within {self.boot_s:g} s",
                    _SILENT_FIX,
                )
            )
        self.identity = reply
        self._push_state()

    def _push_state(self) -> None:
        for command in (f"DIV {self._divider}", "ARM" if self._armed else "DISARM"):
            reply = self._command(command, reconnect=False)
            if reply != "OK":
                raise DeviceError(
                    step_error(f"trigger {command}", f"unexpected reply {reply!r}", _SILENT_FIX)
                )

    def _reconnect(self) -> None:
        self.close()
        self._connect()

    def close(self) -> None:
        """Close the serial port (the device keeps its state)."""
        if self._serial is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                self._serial.close()
            self._serial = None

    def __enter__(self) -> ArduinoTrigger:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- line protocol ----------------------------------------------------------

    def _write(self, command: str) -> None:
        self._serial.write(f"{command}\n".encode("ascii"))
        self._serial.flush()

    def _read_line(self, timeout_s: float) -> str:
        self._serial.timeout = timeout_s
        raw = self._serial.readline()
        if raw and not raw.endswith(b"\n"):
            raw += self._serial.readline()  # a line split by the timeout
        return raw.decode("ascii", errors="replace").strip()

    def _exchange(self, command: str) -> str:
        self._write(command)
        reply = self._read_line(self.timeout_s)
        while reply.startswith("READY"):
            # The device restarted (power, brown-out, a port reopened elsewhere): it lost
            # the divider and armed state and its counters restarted from zero.
            self.resets += 1
            warnings.warn(
                f"trigger on {self.port!r} restarted: state restored, counters restart at 0",
                RuntimeWarning,
                stacklevel=4,
            )
            # A command sent around the restart may or may not be answered: drop
            # whatever is in flight before pushing the state and asking again.
            while self._read_line(0.1):
                pass
            self._push_state()
            self._write(command)
            reply = self._read_line(self.timeout_s)
        return reply

    def _command(self, command: str, *, reconnect: bool = True) -> str:
        """Send one command and return its reply line."""
        if self._serial is None:
            self._reconnect()
        try:
            reply = self._exchange(command)
        except (serial.SerialException, OSError) as exc:
            if not reconnect:
                raise DeviceError(
                    step_error(f"trigger {command}", f"serial link lost ({exc})", _PORT_FIX)
                ) from exc
            self._reconnect()
            reply = self._exchange(command)
        if not reply and reconnect:
            self._reconnect()
            reply = self._exchange(command)
        if not reply:
            raise DeviceError(
                step_error(
                    f"trigger {command}",
                    f"no reply from {self.port!r} within {self.timeout_s:g} s",
                    _SILENT_FIX,
                )
            )
        if reply.startswith("ERR"):
            raise DeviceError(
                step_error(
                    f"trigger {command}",
                    f"the device refused the command ({reply[3:].strip()})",
                    "use ID?, DIV <n>, DIV?, ARM, DISARM, CNT?, STATE? or RST "
                    "(see procedures/firmware/trigger.c)",
                )
            )
        return reply

    def query(self, command: str) -> str:
        """Send a raw protocol command (``"STATE?"``) and return the reply line."""
        return self._command(command)

    # -- Trigger protocol -------------------------------------------------------

    def _arm(self, armed: bool) -> None:
        self._expect_ok("ARM" if armed else "DISARM")

    def _set_divider(self, n: int) -> None:
        self._expect_ok(f"DIV {n}")

    def _expect_ok(self, command: str) -> None:
        reply = self._command(command)
        if reply != "OK":
            raise DeviceError(
                step_error(f"trigger {command}", f"unexpected reply {reply!r}", _SILENT_FIX)
            )

    def counters(self) -> dict[str, int]:
        reply = self._command("CNT?")
        parts = reply.split()
        if len(parts) != 3 or parts[0] != "CNT" or not all(p.isdigit() for p in parts[1:]):
            raise DeviceError(
                step_error("trigger CNT?", f"unexpected reply {reply!r}", _SILENT_FIX)
            )
        return {"received": int(parts[1]), "passed": int(parts[2])}

    def reset_counters(self) -> None:
        """Zero the device's pulse counters."""
        self._expect_ok("RST")
