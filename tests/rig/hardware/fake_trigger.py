"""A pty-based stand-in for the trigger firmware, for fast driver tests."""

from __future__ import annotations

import os
import pty
import select
import threading
import tty
from pathlib import Path


class FakeTrigger:
    """Speaks the firmware's line protocol on a pseudo-terminal.

    ``link`` is a symlink to the current pty (as udev's /dev/serial/by-id links are);
    :meth:`replug` drops the connection and comes back on a new pty, :attr:`silent`
    stops all replies.
    """

    def __init__(self, link: Path) -> None:
        self.link = link
        self.silent = False
        self.identity = "SASSI-TRIGGER 1 FAKE"
        self.received = 0
        self.passed = 0
        self.divider = 1
        self.armed = False
        self.phase = 0
        self.commands: list[str] = []
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
                reply = self.handle(line.decode().strip())
                if reply is not None and not self.silent:
                    os.write(self.master, f"{reply}\n".encode())

    def handle(self, line: str) -> str | None:
        self.commands.append(line)
        if line == "ID?":
            return self.identity
        if line == "ARM" or line == "DISARM":
            self.armed, self.phase = line == "ARM", 0
            return "OK"
        if line.startswith("DIV "):
            value = line[4:]
            if not value.isdigit() or not 1 <= int(value) <= 65535:
                return "ERR divider must be an integer in 1..65535"
            self.divider, self.phase = int(value), 0
            return "OK"
        if line == "CNT?":
            return f"CNT {self.received} {self.passed}"
        return "ERR unknown command"

    def pulse(self) -> None:
        self.received += 1
        if self.armed:
            self.phase += 1
            if self.phase >= self.divider:
                self.phase, self.passed = 0, self.passed + 1

    def announce_reset(self) -> None:
        """Behave like a device that just restarted."""
        self.received = self.passed = self.phase = 0
        self.divider, self.armed = 1, False
        os.write(self.master, b"READY SASSI-TRIGGER 1\n")

    def unplug(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self._slave)

    def replug(self) -> None:
        """Drop the connection and reappear on a new pty behind the same link."""
        self.unplug()
        self.received = self.passed = self.phase = 0
        self.divider, self.armed = 1, False
        self._open()

    def close(self) -> None:
        if not self._stop.is_set():
            self.unplug()
