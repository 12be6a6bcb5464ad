"""Render an HTML report to PNG with headless Chromium, to see it as a person does."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from sassi_bench.errors import step_error

__all__ = ["chromium_path", "screenshot"]

_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def chromium_path() -> str | None:
    """The first Chromium-like browser on ``PATH``, or None.

    Returns
    -------
    str or None
        The browser's path, or None if none of Chromium, chromium-browser, google-chrome
        or google-chrome-stable is on ``PATH``.

    Examples
    --------
    >>> chromium_path() is None or chromium_path().startswith("/")
    True
    """
    for name in _NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


def screenshot(
    html: str | os.PathLike[str],
    png: str | os.PathLike[str],
    *,
    width: int = 1400,
    height: int = 4200,
    timeout_s: float = 60.0,
) -> Path:
    """Render ``html`` into ``png`` (a ``width`` x ``height`` window) with headless Chromium.

    Parameters
    ----------
    html
        The HTML file to render.
    png
        The PNG file to write.
    width, height
        The browser window in CSS pixels; the page is cut at ``height``.
    timeout_s
        Seconds Chromium may take.

    Returns
    -------
    pathlib.Path
        The absolute path of the PNG written.

    Raises
    ------
    FileNotFoundError
        If no Chromium is installed (Debian: ``apt-get install chromium``).

    Examples
    --------
    Not run here (it needs Chromium and a written report)::

        screenshot("report/macbeth_report.html", "report.png")
        # PosixPath('report.png')
    """
    browser = chromium_path()
    if browser is None:
        raise FileNotFoundError(
            step_error(
                "report screenshot",
                "no Chromium browser on PATH",
                "install it (Debian: apt-get install chromium)",
            )
        )
    source = Path(html).resolve()
    target = Path(png).resolve()
    command = [
        browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
        f"--screenshot={target}", f"--window-size={width},{height}", source.as_uri(),
    ]  # fmt: skip
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, check=False)
    if done.returncode != 0 or not target.is_file():
        raise RuntimeError(
            step_error(
                "report screenshot",
                f"Chromium exited with {done.returncode}: {done.stderr.strip()[-400:]}",
                "run the command by hand to see why",
            )
        )
    return target
