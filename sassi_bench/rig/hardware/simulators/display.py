"""A virtual dual-head X server (Xorg's dummy driver): the SLM's monitor without an SLM.

:class:`DummyXServer` starts Xorg with two monitors, ``DUMMY0`` (the operator's) and
``DUMMY1`` (the SLM's, of the SLM's size, to its right), so the SLM window
(:class:`~sassi_bench.rig.hardware.slm_display.DisplaySlm`) opens, places itself and paints
as on a bench, and what it shows can be grabbed back from the server
(:meth:`DummyXServer.grab_slm`).

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    import tempfile, pathlib
    if xorg_missing() is None:
        server = DummyXServer(pathlib.Path(tempfile.mkdtemp()), (640, 400))
        server.slm
        server.close()
    # ('DUMMY1', 640, 400, 800, 0)
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import select
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["INSTALL_HINT", "DummyXServer", "xorg_missing"]

INSTALL_HINT = "apt-get install xserver-xorg-core xserver-xorg-video-dummy x11-xserver-utils"

XORG_CONF = """\
Section "ServerFlags"
  Option "AutoAddDevices" "false"
  Option "AutoEnableDevices" "false"
  Option "DontVTSwitch" "true"
EndSection
Section "Device"
  Identifier "dummy"
  Driver "dummy"
  VideoRam 65536
EndSection
Section "Monitor"
  Identifier "monitor"
  HorizSync 5.0-1000.0
  VertRefresh 5.0-200.0
EndSection
Section "Screen"
  Identifier "screen"
  Device "dummy"
  Monitor "monitor"
  DefaultDepth 24
  SubSection "Display"
    Depth 24
    Virtual 4096 2048
  EndSubSection
EndSection
"""


def xorg_missing() -> str | None:
    """Why a dummy X server cannot start here, or None."""
    for tool in ("Xorg", "xrandr"):
        if shutil.which(tool) is None:
            return f"{tool} not found; {INSTALL_HINT}"
    drivers = Path("/usr/lib/xorg/modules/drivers")
    if not (drivers / "dummy_drv.so").is_file():
        return f"Xorg's dummy video driver is missing; {INSTALL_HINT}"
    return None


def _die_with_parent() -> None:  # pragma: no cover - runs in the child
    """Linux: the X server ends when the process that started it dies (even killed)."""
    with contextlib.suppress(OSError):
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG


def _read_display_number(fd: int, proc: subprocess.Popen, log: Path) -> int:
    """The display number Xorg writes to ``-displayfd`` once it listens on it."""
    deadline = time.monotonic() + 15
    text = b""
    while not text.endswith(b"\n"):
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            chunk = os.read(fd, 16)
            if not chunk:
                break
            text += chunk
        elif proc.poll() is not None or time.monotonic() > deadline:
            break
    if not text.strip().isdigit():
        raise RuntimeError(f"Xorg did not report a display number; see {log}")
    return int(text)


class DummyXServer:
    """Xorg with two monitors: DUMMY0 (the operator's) and DUMMY1 (the SLM) to its right."""

    def __init__(self, workdir: Path, slm_size: tuple[int, int], main_size=(800, 600)) -> None:
        conf = workdir / "xorg.conf"
        conf.write_text(XORG_CONF)
        (workdir / "conf.d").mkdir(exist_ok=True)
        self.log = workdir / "xorg.log"
        # Xorg picks a free display itself (-displayfd): two test processes starting a
        # server at once cannot both take the number a lock-file scan found free.
        read_fd, write_fd = os.pipe()
        try:
            self.proc = subprocess.Popen(
                [
                    "Xorg",
                    "-displayfd",
                    str(write_fd),
                    "-config",
                    str(conf),
                    "-configdir",
                    str(workdir / "conf.d"),
                    "-noreset",
                    "-nolisten",
                    "tcp",
                    "-logfile",
                    str(self.log),
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                pass_fds=(write_fd,),
                preexec_fn=_die_with_parent,
            )
        finally:
            os.close(write_fd)
        try:
            self.number = _read_display_number(read_fd, self.proc, self.log)
        except RuntimeError:
            self.close()
            raise
        finally:
            os.close(read_fd)
        self.display = f":{self.number}"
        deadline = time.monotonic() + 15
        while self._xrandr().returncode != 0:
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.close()
                raise RuntimeError(f"Xorg {self.display} did not start; see {self.log}")
            time.sleep(0.05)
        self.main = ("DUMMY0", *main_size, 0, 0)
        self.slm = ("DUMMY1", *slm_size, main_size[0], 0)
        self._set_output("DUMMY0", main_size, 0)
        self._set_output("DUMMY1", slm_size, main_size[0])
        # A full query (XRRGetScreenResources) makes the server publish the new layout
        # to clients that only read the current one, as screeninfo does.
        self._xrandr(check=True)

    def _xrandr(self, *args: str, check: bool = False) -> subprocess.CompletedProcess:
        env = {**os.environ, "DISPLAY": self.display}
        return subprocess.run(
            ["xrandr", *args], env=env, capture_output=True, text=True, check=check
        )

    def _set_output(self, output: str, size: tuple[int, int], x: int) -> None:
        w, h = size
        mode = f"sassi{w}x{h}"
        # Timings are irrelevant to the dummy driver; a 60 Hz-ish modeline for any size.
        timing = [str(w), str(w + 8), str(w + 16), str(w + 24)]
        timing += [str(h), str(h + 2), str(h + 4), str(h + 6)]
        clock = f"{(w + 24) * (h + 6) * 60 / 1e6:.2f}"
        if mode not in self._xrandr().stdout:
            self._xrandr("--newmode", mode, clock, *timing, check=True)
        self._xrandr("--addmode", output, mode, check=True)
        self._xrandr("--output", output, "--mode", mode, "--pos", f"{x}x0", check=True)

    def grab_slm(self) -> NDArray[np.uint8]:
        """The SLM monitor's pixels as the X server has them (green channel, uint8)."""
        import mss

        _, width, height, left, top = self.slm
        region = {"left": left, "top": top, "width": width, "height": height}
        if getattr(self, "_mss", None) is None:
            self._mss = mss.MSS(display=self.display)
        pixels = np.asarray(self._mss.grab(region))  # BGRA
        return np.ascontiguousarray(pixels[..., 1])

    def close(self) -> None:
        """Stop the server."""
        grabber = getattr(self, "_mss", None)
        if grabber is not None:
            grabber.close()
            self._mss = None
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
