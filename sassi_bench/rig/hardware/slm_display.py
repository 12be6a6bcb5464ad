"""An SLM driven as a monitor: patterns shown full screen, pixel for pixel.

LCoS SLMs such as the Holoeye HES 6001 appear to the computer as a second monitor.
:class:`DisplaySlm` opens a frameless full-screen PySide6 window on that monitor
(geometry from screeninfo) and paints the 8-bit pattern 1:1 into it: no scaling, no
smoothing, no colour management, the same grey level on the red, green and blue
channels. The SLM's own master pulse then tells the trigger a new pattern is on.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.base import SlmBase
from sassi_bench.rig.hardware import require

__all__ = ["DisplaySlm", "find_monitor"]


# Qt platforms that draw into memory only: a pattern shown there reaches no SLM.
_NO_MONITOR_PLATFORMS = frozenset({"offscreen", "minimal", "vnc"})


def find_monitor(monitor: int | str, monitors: list[Any]) -> Any:
    """Pick a monitor by index or output name (``"HDMI-1"``) from screeninfo's list.

    Examples
    --------
    >>> from types import SimpleNamespace as M
    >>> mons = [M(name="eDP-1", width=1920, height=1200), M(name="HDMI-1", width=1920, height=1080)]
    >>> find_monitor("HDMI-1", mons).height, find_monitor(0, mons).name
    (1080, 'eDP-1')
    """
    names = [f"{i}: {m.name} {m.width}x{m.height}" for i, m in enumerate(monitors)]
    if isinstance(monitor, int) and not isinstance(monitor, bool):
        if 0 <= monitor < len(monitors):
            return monitors[monitor]
    else:
        for m in monitors:
            if m.name == monitor:
                return m
    raise DeviceError(
        step_error(
            "SLM display",
            f"no monitor {monitor!r}; connected: {', '.join(names) or 'none'}",
            "set hardware.slm.monitor in the rig YAML to one of these indices or names",
        )
    )


class DisplaySlm(SlmBase):
    """An SLM that is a monitor of this computer.

    Parameters
    ----------
    shape
        The SLM's (height, width); the monitor's mode must match it exactly.
    monitor
        Index in screeninfo's monitor list or output name (``"DP-2"``).
    on_display
        Called after every pattern is on screen (tests wire a pulse source here; on
        a real bench the SLM sends its own master pulse).

    Raises
    ------
    DeviceError
        If PySide6 or screeninfo is missing, the monitor does not exist or its mode
        differs from ``shape``, or the desktop scales the window.

    Examples
    --------
    Not run here (it needs the hardware)::

        slm = DisplaySlm((1080, 1920), monitor="HDMI-1")
        slm.show(np.zeros((1080, 1920), np.uint8))
        # 0
    """

    def __init__(
        self,
        shape: tuple[int, int],
        monitor: int | str = 1,
        *,
        on_display: Callable[[], None] | None = None,
    ) -> None:
        super().__init__(shape)
        screeninfo = require("screeninfo", "screeninfo", "SLM display")
        qt_core = require("PySide6.QtCore", "PySide6", "SLM display")
        qt_gui = require("PySide6.QtGui", "PySide6", "SLM display")
        qt_widgets = require("PySide6.QtWidgets", "PySide6", "SLM display")
        try:
            monitors = list(screeninfo.get_monitors())
        except Exception as exc:  # screeninfo raises its own error type per platform
            raise DeviceError(
                step_error(
                    "SLM display",
                    f"cannot list monitors ({exc})",
                    "run on the bench's desktop session (check DISPLAY on Linux)",
                )
            ) from exc
        mon = find_monitor(monitor, monitors)
        height, width = self.shape
        if (mon.width, mon.height) != (width, height):
            raise DeviceError(
                step_error(
                    "SLM display",
                    f"monitor {mon.name} is {mon.width}x{mon.height}, the rig's SLM is "
                    f"{width}x{height}",
                    "pick the SLM's monitor or set its native mode "
                    f"(e.g. xrandr --output {mon.name} --mode {width}x{height})",
                )
            )
        self.monitor = mon
        self._on_display = on_display
        self._frame = np.zeros(self.shape, dtype=np.uint8)
        os.environ.setdefault("QT_ENABLE_HIGHDPI_SCALING", "0")
        self._app = qt_widgets.QApplication.instance() or qt_widgets.QApplication([])
        platform = self._app.platformName()
        if platform in _NO_MONITOR_PLATFORMS:
            raise DeviceError(
                step_error(
                    "SLM display",
                    f"Qt in this process draws to its '{platform}' platform, which reaches no "
                    "monitor (QT_QPA_PLATFORM, or a Qt application started before the SLM)",
                    "unset QT_QPA_PLATFORM (or set it to xcb, wayland or windows) and start a "
                    "new Python process",
                )
            )
        image = qt_gui.QImage(
            self._frame.data, width, height, width, qt_gui.QImage.Format.Format_Grayscale8
        )
        self._window = _make_window(qt_core, qt_gui, qt_widgets, image)
        self._window.setGeometry(mon.x, mon.y, width, height)
        for screen in self._app.screens():
            geo = screen.geometry()
            if (geo.x(), geo.y(), geo.width(), geo.height()) == (mon.x, mon.y, width, height):
                self._window.setScreen(screen)
        self._window.showFullScreen()
        self._wait_exposed()
        ratio = self._window.devicePixelRatioF()
        if ratio != 1.0:
            self.close()
            raise DeviceError(
                step_error(
                    "SLM display",
                    f"the desktop scales windows on {mon.name} by {ratio:g}",
                    "set the monitor's scale to 100% (or QT_SCALE_FACTOR=1) so one pattern "
                    "pixel is one SLM pixel",
                )
            )

    def _wait_exposed(self, timeout_s: float = 5.0) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self._app.processEvents()
            handle = self._window.windowHandle()
            if handle is not None and handle.isExposed():
                return
            time.sleep(0.01)
        raise DeviceError(
            step_error(
                "SLM display",
                f"the pattern window on {self.monitor.name} was not shown within {timeout_s:g} s",
                "check the monitor is enabled in the desktop's display settings",
            )
        )

    def _display(self, pattern: NDArray[np.uint8]) -> None:
        np.copyto(self._frame, pattern)
        self._window.repaint()  # synchronous: painted before returning
        self._app.processEvents()
        # A round trip to the window system: the server holds the pattern before the
        # trigger fires (on X, painting is only queued on the connection until then).
        self._app.sync()
        if self._on_display is not None:
            self._on_display()

    def close(self) -> None:
        """Close the pattern window."""
        self._window.close()
        self._app.processEvents()


def _make_window(qt_core: Any, qt_gui: Any, qt_widgets: Any, image: Any) -> Any:
    """A frameless widget that paints ``image`` at (0, 0), unscaled."""

    class PatternWindow(qt_widgets.QWidget):
        def __init__(self) -> None:
            flags = qt_core.Qt.WindowType.FramelessWindowHint
            flags |= qt_core.Qt.WindowType.WindowStaysOnTopHint
            super().__init__(None, flags)
            self.image = image
            self.setAttribute(qt_core.Qt.WidgetAttribute.WA_OpaquePaintEvent)
            self.setAttribute(qt_core.Qt.WidgetAttribute.WA_NoSystemBackground)
            self.setCursor(qt_core.Qt.CursorShape.BlankCursor)
            self.setWindowTitle("sassi-bench SLM")

        def setScreen(self, screen: Any) -> None:
            self.winId()  # create the native window so it can be moved to the screen
            self.windowHandle().setScreen(screen)

        def paintEvent(self, event: Any) -> None:
            painter = qt_gui.QPainter(self)
            painter.setRenderHint(qt_gui.QPainter.RenderHint.SmoothPixmapTransform, False)
            painter.setCompositionMode(qt_gui.QPainter.CompositionMode.CompositionMode_Source)
            painter.drawImage(qt_core.QPoint(0, 0), self.image)
            painter.end()

    return PatternWindow()
