"""The trigger firmware running in simavr, bridged to a pseudo-terminal."""

from __future__ import annotations

import queue
import shutil
import subprocess
import threading
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
FIRMWARE_DIR = REPO / "procedures" / "firmware"
HARNESS_SOURCE = Path(__file__).with_name("simavr_harness.c")
SIMAVR_INCLUDE = Path("/usr/include/simavr")
INSTALL_HINT = "apt-get install gcc-avr avr-libc libsimavr-dev (what .ci/run installs)"


def toolchain_missing() -> str | None:
    """Why the firmware tests cannot run here, or None."""
    for tool in ("make", "avr-gcc", "avr-objcopy", "cc"):
        if shutil.which(tool) is None:
            return f"{tool} not found; {INSTALL_HINT}"
    if not (SIMAVR_INCLUDE / "sim_avr.h").is_file():
        return f"simavr headers not found in {SIMAVR_INCLUDE}; {INSTALL_HINT}"
    return None


def build_firmware(build: Path) -> Path:
    """Build the trigger firmware with its Makefile into ``build``; return the ELF."""
    subprocess.run(
        ["make", "-s", "-C", str(FIRMWARE_DIR), f"BUILD={build}"],
        check=True,
        capture_output=True,
        text=True,
    )
    return build / "trigger.elf"


def build_harness(build: Path) -> Path:
    """Compile the simavr harness against libsimavr."""
    exe = build / "simavr_harness"
    subprocess.run(
        [
            "cc",
            "-O2",
            f"-I{SIMAVR_INCLUDE}",
            "-o",
            str(exe),
            str(HARNESS_SOURCE),
            "-lsimavr",
            "-lpthread",
            "-lutil",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return exe


class SimavrDevice:
    """One simulated Arduino: ``port`` for the driver, ``pulse()`` on the SLM input pin."""

    def __init__(self, harness: Path, firmware: Path) -> None:
        self.proc = subprocess.Popen(
            [str(harness), str(firmware)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        self.outputs: list[int] = []
        self._done: queue.Queue[str] = queue.Queue()
        self._port: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        try:
            self.port = self._port.get(timeout=10)
        except queue.Empty:
            self.close()
            pytest.fail(f"simavr harness printed no pty path: {self.proc.stderr.read()}")

    def _read(self) -> None:
        for line in self.proc.stdout:
            words = line.split()
            if words[:1] == ["PTY"]:
                self._port.put(words[1])
            elif words[:1] == ["OUT"]:
                self.outputs.append(int(words[1]))
            elif words[:1] == ["DONE"]:
                self._done.put(words[1])

    def _ask(self, command: str) -> None:
        self.proc.stdin.write(f"{command}\n")
        self.proc.stdin.flush()
        assert self._done.get(timeout=10) == command

    def pulse(self, n: int = 1) -> None:
        """Send ``n`` SLM master pulses and wait until the firmware handled them."""
        for _ in range(n):
            self._ask("p")

    def reset(self) -> None:
        """Reset the MCU, as a brown-out or a port opened elsewhere would."""
        self._ask("r")

    @property
    def camera_pulses(self) -> int:
        """Rising edges seen on the camera output D4."""
        return sum(1 for a, b in zip([0, *self.outputs], self.outputs, strict=False) if b > a)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(timeout=5)
        self.proc.stdout.close()
        self.proc.stderr.close()
