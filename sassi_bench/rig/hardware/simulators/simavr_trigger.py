"""The trigger firmware itself, running in simavr behind a pseudo-terminal.

:class:`SimavrTrigger` builds ``procedures/firmware/trigger.c`` with its Makefile (avr-gcc)
and a small harness against libsimavr (``simavr_harness.c``, beside this module), then
runs the firmware on a simulated ATmega328P: its UART is bridged to a pty that
:class:`~sassi_bench.rig.hardware.trigger.ArduinoTrigger` opens as any serial port, an SLM
master pulse on D2 is simulated cycle by cycle, and every change of the camera output D4
is reported. It is the trigger behind ``--simulate`` where the toolchain is installed;
elsewhere the line-protocol fake :class:`~.serial_trigger.TriggerSimulator` stands in
(:func:`trigger_simulator` chooses, and says which one runs).

Examples
--------
Not run here (it needs avr-gcc and libsimavr)::

    trigger = SimavrTrigger(Path(tempfile.mkdtemp()))
    driver = ArduinoTrigger(str(trigger.link))
    driver.arm(); trigger.pulse()  # True: passed to the cameras
    driver.close(); trigger.close()
"""

from __future__ import annotations

import queue
import shutil
import subprocess
import threading
from pathlib import Path

from sassi_bench.errors import DeviceError, step_error

__all__ = [
    "SimavrTrigger",
    "build_firmware",
    "build_harness",
    "simavr_missing",
    "trigger_simulator",
]

#: The firmware's source: in a source checkout, ``procedures/firmware`` at its root.
FIRMWARE_DIR = Path(__file__).resolve().parents[4] / "procedures" / "firmware"
HARNESS_SOURCE = Path(__file__).with_name("simavr_harness.c")
SIMAVR_INCLUDE = Path("/usr/include/simavr")
INSTALL_HINT = "apt-get install gcc-avr avr-libc libsimavr-dev (what .ci/run installs)"
#: How long one harness command (a pulse, a reset, the pty's path) may take to answer.
_ANSWER_S = 10.0


def simavr_missing() -> str | None:
    """Why the firmware cannot run in simavr here, or None.

    Examples
    --------
    >>> simavr_missing() is None or "install" in simavr_missing() or "firmware" in simavr_missing()
    True
    """
    for tool in ("make", "avr-gcc", "avr-objcopy", "cc"):
        if shutil.which(tool) is None:
            return f"{tool} not found; {INSTALL_HINT}"
    if not (SIMAVR_INCLUDE / "sim_avr.h").is_file():
        return f"simavr headers not found in {SIMAVR_INCLUDE}; {INSTALL_HINT}"
    if not (FIRMWARE_DIR / "trigger.c").is_file():
        return f"the firmware's source is not at {FIRMWARE_DIR} (run from a source checkout)"
    return None


def _run(step: str, argv: list[str]) -> None:
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        last = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or ["no output"]
        raise DeviceError(
            step_error(step, f"{argv[0]} failed: {last[0]}", f"check the toolchain: {INSTALL_HINT}")
        )


def build_firmware(build: Path) -> Path:
    """Build the trigger firmware with its Makefile into ``build``; return the ELF."""
    _run("trigger firmware build", ["make", "-s", "-C", str(FIRMWARE_DIR), f"BUILD={build}"])
    return build / "trigger.elf"


def build_harness(build: Path) -> Path:
    """Compile the simavr harness against libsimavr into ``build``; return it."""
    exe = build / "simavr_harness"
    _run(
        "simavr harness build",
        ["cc", "-O2", f"-I{SIMAVR_INCLUDE}", "-o", str(exe), str(HARNESS_SOURCE),
         "-lsimavr", "-lpthread", "-lutil"],
    )  # fmt: skip
    return exe


class SimavrTrigger:
    """One simulated Arduino running the trigger firmware.

    Parameters
    ----------
    workdir
        Where the firmware and harness are built (unless given) and the port's link made.
    firmware, harness
        Already built ones (the tests build them once).

    Attributes
    ----------
    link
        A symlink to the pty the firmware's UART speaks on: the driver's port.
    port
        The pty itself.
    outputs
        Every level the camera output D4 took, in order.
    """

    #: What ``rig check --simulate`` says runs behind the trigger's adapter.
    description = "the trigger firmware in simavr"

    def __init__(
        self, workdir: Path, firmware: Path | None = None, harness: Path | None = None
    ) -> None:
        workdir = Path(workdir)
        firmware = firmware or build_firmware(workdir / "firmware")
        harness = harness or build_harness(workdir)
        self.proc = subprocess.Popen(
            [str(harness), str(firmware)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        self.outputs: list[int] = []
        self._lock = threading.Lock()
        self._done: queue.Queue[str] = queue.Queue()
        self._port: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        try:
            self.port = self._port.get(timeout=_ANSWER_S)
        except queue.Empty:
            self.close()
            raise DeviceError(
                step_error(
                    "trigger firmware in simavr",
                    "the harness printed no pseudo-terminal",
                    f"check libsimavr ({INSTALL_HINT})",
                )
            ) from None
        self.link = workdir / "ttyTRIGGER"
        self.link.unlink(missing_ok=True)
        self.link.symlink_to(self.port)

    def _read(self) -> None:
        for line in self.proc.stdout:
            words = line.split()
            if words[:1] == ["PTY"]:
                self._port.put(words[1])
            elif words[:1] == ["OUT"]:
                self.outputs.append(int(words[1]))
            elif words[:1] == ["DONE"]:
                self._done.put(words[1])
        self._done.put("")  # the harness is gone: no answer will come

    def _ask(self, command: str) -> None:
        try:
            self.proc.stdin.write(f"{command}\n")
            self.proc.stdin.flush()
            answer = self._done.get(timeout=_ANSWER_S)
            if not answer:
                raise OSError("the harness exited")
        except (OSError, queue.Empty):
            raise DeviceError(
                step_error(
                    "trigger firmware in simavr",
                    f"the simulation stopped answering (exit status {self.proc.poll()})",
                    "close the rig and open it again",
                )
            ) from None
        if answer != command:
            raise DeviceError(
                step_error(
                    "trigger firmware in simavr",
                    f"the harness answered out of turn to {command!r}",
                    "close the rig and open it again",
                )
            )

    @property
    def camera_pulses(self) -> int:
        """Rising edges seen on the camera output D4."""
        levels = self.outputs
        return sum(1 for a, b in zip([0, *levels], levels, strict=False) if b > a)

    def pulse(self) -> bool:
        """One SLM master pulse on D2; True when the firmware passed it to the cameras."""
        with self._lock:
            before = self.camera_pulses
            self._ask("p")
            return self.camera_pulses > before

    def reset(self) -> None:
        """Reset the MCU, as a brown-out or a port opened elsewhere would."""
        with self._lock:
            self._ask("r")

    def close(self) -> None:
        """Stop the simulation and remove the port's link."""
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
        if hasattr(self, "link"):
            self.link.unlink(missing_ok=True)


def trigger_simulator(workdir: Path) -> tuple[object, str]:
    """The trigger behind ``--simulate``: the firmware in simavr where it can run here,
    else the serial fake of its protocol; with a line saying which one runs and why.

    Returns
    -------
    tuple
        (simulator with ``link``, ``pulse()`` and ``close()``, what runs).
    """
    from sassi_bench.rig.hardware.simulators.serial_trigger import TriggerSimulator

    reason = simavr_missing()
    if reason is None:
        return SimavrTrigger(workdir), SimavrTrigger.description
    fake = TriggerSimulator(workdir / "ttyTRIGGER")
    return fake, f"a serial fake of the trigger firmware's protocol ({reason})"
