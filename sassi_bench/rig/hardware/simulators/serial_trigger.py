"""The trigger firmware's line protocol spoken on a pseudo-terminal.

:class:`TriggerSimulator` answers :class:`~sassi_bench.rig.hardware.trigger.ArduinoTrigger`
over a real serial link (a pty, opened by pyserial as any port) exactly as
``procedures/firmware/trigger.c`` does: ``ID?``, ``DIV <n>``, ``DIV?``, ``ARM``,
``DISARM``, ``CNT?``, ``STATE?``, ``RST``, ``ERR`` for anything else, ``READY`` after a
reset. :meth:`~TriggerSimulator.pulse` is an SLM master pulse on D2: counted, and passed
to the cameras (every n-th while armed). It stands in for the firmware where the AVR
toolchain and simavr are not installed (the tests run the firmware itself in simavr).

Examples
--------
>>> import tempfile, pathlib
>>> from sassi_bench.rig.hardware.trigger import ArduinoTrigger
>>> sim = TriggerSimulator(pathlib.Path(tempfile.mkdtemp()) / "ttySIM")
>>> trigger = ArduinoTrigger(str(sim.link), boot_s=1.0)
>>> trigger.arm(); sim.pulse()
True
>>> trigger.counters()
{'received': 1, 'passed': 1}
>>> trigger.close(); sim.close()
"""

from __future__ import annotations

import os
import pty
import select
import threading
import tty
from pathlib import Path

__all__ = ["TriggerSimulator"]


class TriggerSimulator:
    """Speaks the firmware's line protocol on a pseudo-terminal.

    Parameters
    ----------
    link
        A symlink made to the current pty (as udev's ``/dev/serial/by-id`` links are);
        give it to the driver as the port.

    :meth:`replug` drops the connection and comes back on a new pty behind the same
    link; :attr:`silent` stops all replies; :attr:`identity` is what ``ID?`` answers.
    """

    def __init__(self, link: Path) -> None:
        self.link = Path(link)
        self.silent = False
        self.identity = "SASSI-TRIGGER 1 SIMULATED"
        self.received = 0
        self.passed = 0
        self.divider = 1
        self.armed = False
        self.phase = 0
        self.commands: list[str] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._open()

    def _open(self) -> None:
        self.master, slave = pty.openpty()
        tty.setraw(slave)
        self.slave_path = os.ttyname(slave)
        self._slave = slave
        tmp = self.link.with_suffix(".new")
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(self.slave_path)
        tmp.replace(self.link)
        self._stop.clear()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        buffer = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.02)
            if not ready:
                continue
            try:
                data = os.read(self.master, 1024)
            except OSError:
                return
            buffer += data
            while b"\n" in buffer:
                line, buffer = buffer.split(b"\n", 1)
                reply = self.handle(line.decode(errors="replace").strip())
                if reply is not None and not self.silent:
                    os.write(self.master, f"{reply}\n".encode())

    def handle(self, line: str) -> str | None:
        """The reply to one command line."""
        with self._lock:
            self.commands.append(line)
            if line == "ID?":
                return self.identity
            if line in ("ARM", "DISARM"):
                self.armed, self.phase = line == "ARM", 0
                return "OK"
            if line.startswith("DIV "):
                value = line[4:]
                if not value.isdigit() or not 1 <= int(value) <= 65535:
                    return "ERR divider must be an integer in 1..65535"
                self.divider, self.phase = int(value), 0
                return "OK"
            if line == "DIV?":
                return f"DIV {self.divider}"
            if line == "CNT?":
                return f"CNT {self.received} {self.passed}"
            if line == "STATE?":
                return f"STATE {int(self.armed)} {self.divider}"
            if line == "RST":
                self.received = self.passed = 0
                return "OK"
            return "ERR unknown command"

    def pulse(self) -> bool:
        """An SLM master pulse on D2; True when it is passed to the cameras."""
        with self._lock:
            self.received += 1
            if not self.armed:
                return False
            self.phase += 1
            if self.phase < self.divider:
                return False
            self.phase, self.passed = 0, self.passed + 1
            return True

    def announce_reset(self) -> None:
        """Behave like a device that just restarted."""
        with self._lock:
            self.received = self.passed = self.phase = 0
            self.divider, self.armed = 1, False
        os.write(self.master, b"READY SASSI-TRIGGER 1\n")

    def unplug(self) -> None:
        """Drop the connection (the pty goes away)."""
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self._slave)

    def replug(self) -> None:
        """Drop the connection and reappear on a new pty behind the same link."""
        self.unplug()
        with self._lock:
            self.received = self.passed = self.phase = 0
            self.divider, self.armed = 1, False
        self._open()

    def close(self) -> None:
        """Stop answering and remove the link."""
        if not self._stop.is_set():
            self.unplug()
        self.link.unlink(missing_ok=True)
