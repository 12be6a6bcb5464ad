"""A JupyterLab server started by the tests, a headless Chromium driven by Playwright, and a
second client on the notebook's kernel to read what it holds.

The notebooks are copied into a temporary folder (the server's root, where a saved
notebook goes) and run on the virtual bench with ``SASSI_BENCH_DATA`` in another
temporary folder. Chromium is the system's (Debian: ``apt-get install chromium``), driven
through Python Playwright with ``executable_path``: nothing downloads a browser.
"""

from __future__ import annotations

import ast
import json
import os
import re
import secrets
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from sassi_bench.plots.screenshot import chromium_path

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"
#: Flags for a headless Chromium on a machine with no network beyond loopback.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
#: JupyterLab settings for a quiet test page: no news, no update checks.
LAB_SETTINGS = {
    "@jupyterlab/apputils-extension/notification.jupyterlab-settings": {
        "fetchNews": "false",
        "checkForUpdates": False,
    },
    # The notebook's own kernel starts without asking, however slowly the server answers
    # (on a loaded machine JupyterLab otherwise asks with a "Select Kernel" dialog).
    "@jupyterlab/notebook-extension/tracker.jupyterlab-settings": {"autoStartDefaultKernel": True},
    # Widget state saved with the notebook: a reopened notebook shows its choices.
    "@jupyter-widgets/jupyterlab-manager/plugin.jupyterlab-settings": {"saveState": True},
}
CELL_TIMEOUT_S = 600
#: A cell neither queued nor run this long after Run was pressed did not get the press.
START_TIMEOUT_S = 20


def _requirements() -> str | None:
    """Why the browser tests cannot run here, or None."""
    try:
        import jupyter_client  # noqa: F401
        import jupyterlab  # noqa: F401
        import playwright.sync_api  # noqa: F401
    except ImportError as exc:
        return f"{exc.name} is not installed (pip install -e '.[dev]' installs it)"
    if chromium_path() is None:
        return "no Chromium to drive (Debian: apt-get install chromium; .ci/run installs it)"
    return None


def pytest_collection_modifyitems(items):
    why = _requirements()
    if why is None:
        return
    here = Path(__file__).parent
    for item in items:
        if here in Path(item.fspath).parents:
            item.add_marker(pytest.mark.skip(reason=f"browser tests: {why}"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class Lab:
    """A running JupyterLab: its address, token and folders."""

    url: str
    token: str
    root: Path
    data: Path
    runtime: Path

    def api(self, path: str) -> Any:
        request = urllib.request.Request(
            f"{self.url}/api/{path}", headers={"Authorization": f"token {self.token}"}
        )
        with urllib.request.urlopen(request, timeout=10) as response:
            return json.loads(response.read())


@pytest.fixture(scope="module")
def lab(module_folder):
    """JupyterLab on a free loopback port, serving copies of the notebooks."""
    top = module_folder("browser-lab")
    root, data, runtime, settings = (top / n for n in ("lab", "data", "runtime", "settings"))
    for folder in (root, data, runtime):
        folder.mkdir()
    for path in NOTEBOOKS.glob("*.ipynb"):
        shutil.copy(path, root / path.name)
    for name, value in LAB_SETTINGS.items():
        target = settings / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps(value))
    token, port = secrets.token_hex(16), _free_port()
    env = {
        **os.environ,
        "SASSI_BENCH_DATA": str(data),
        "MPLBACKEND": "Agg",
        "JUPYTER_RUNTIME_DIR": str(runtime),
        "JUPYTERLAB_SETTINGS_DIR": str(settings),
        "JUPYTER_CONFIG_DIR": str(top / "config"),
    }
    log = (top / "jupyterlab.log").open("wb")
    server = subprocess.Popen(
        [
            sys.executable, "-m", "jupyterlab", "--no-browser", "--ServerApp.ip=127.0.0.1",
            f"--ServerApp.port={port}", f"--IdentityProvider.token={token}",
            f"--ServerApp.root_dir={root}", "--LabApp.news_url=",
            "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
            "--ServerApp.terminals_enabled=False",
            *(["--allow-root"] if os.geteuid() == 0 else []),  # CI containers run as root
        ],
        env=env, stdout=log, stderr=subprocess.STDOUT, cwd=root,
    )  # fmt: skip
    started = Lab(f"http://127.0.0.1:{port}", token, root, data, runtime)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                started.api("status")
                break
            except OSError:
                if server.poll() is not None or time.monotonic() > deadline:
                    log.flush()
                    raise RuntimeError(
                        "JupyterLab did not start:\n" + (top / "jupyterlab.log").read_text()[-3000:]
                    ) from None
                time.sleep(0.5)
        yield started
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        log.close()


@pytest.fixture(scope="module")
def browser():
    """Headless system Chromium under Playwright."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as driver:
        chromium = driver.chromium.launch(
            executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield chromium
        finally:
            chromium.close()


class Notebook:
    """One notebook open in JupyterLab: run cells by the keyboard, read their outputs, and
    ask its kernel what it holds (through a second client of the same kernel)."""

    def __init__(self, lab: Lab, page, name: str) -> None:
        self.lab, self.page, self.name = lab, page, name
        self._kernel = None

    def open(self) -> Notebook:
        # ?reset: a new page shows this notebook alone, not the layout an earlier page left.
        self.page.goto(f"{self.lab.url}/lab/tree/{self.name}?reset&token={self.lab.token}")
        self.page.locator(".lm-TabBar-tab.lm-mod-current").filter(
            has_text=self.name
        ).first.wait_for(timeout=60_000)
        self.page.locator(".jp-Notebook .jp-Cell").first.wait_for(timeout=60_000)
        self.page.locator(
            ".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Notebook-ExecutionIndicator"
            "[data-status='idle']"
        ).wait_for(timeout=120_000)
        return self

    def cell(self, index: int):
        return self.page.locator(".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Notebook .jp-Cell").nth(
            index
        )

    def _prompt(self, index: int) -> str:
        return self.cell(index).locator(".jp-InputArea-prompt").inner_text()

    def run(self, index: int) -> str:
        """Run cell ``index`` as a person does (select it, press the toolbar's Run), wait
        for it, and return its output text; a traceback fails the test."""
        before = self._prompt(index)
        started = time.monotonic()
        self._press_run(index)
        while True:
            prompt = self._prompt(index)
            if re.search(r"\[\d+\]", prompt) and prompt != before:
                break
            waited = time.monotonic() - started
            assert waited < CELL_TIMEOUT_S, f"{self.name}: cell {index} still running ({prompt})"
            if prompt == before and waited > START_TIMEOUT_S:
                # Neither queued nor run: the press went nowhere (the page was still
                # laying out); nothing ran, so pressing again runs it once.
                self._press_run(index)
                started = time.monotonic()
            time.sleep(0.25)
        text = self.output(index)
        assert "Traceback" not in text, f"{self.name}: cell {index} failed:\n{text[-3000:]}"
        return text

    def _press_run(self, index: int) -> None:
        dialog = self.page.locator(".jp-Dialog")
        if dialog.count():  # it would take every click: say what JupyterLab asks
            raise AssertionError(
                f"{self.name}: JupyterLab shows a dialog: {dialog.first.inner_text()}"
            )
        cell = self.cell(index)
        cell.locator(".jp-InputArea-prompt").click()
        self.page.wait_for_function(
            "cell => cell.classList.contains('jp-mod-active')", arg=cell.element_handle()
        )
        self.page.locator(
            ".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Toolbar "
            "[data-command='notebook:run-cell-and-select-next']"
        ).click()

    def run_all(self, indices) -> None:
        for index in indices:
            self.run(index)

    def output(self, index: int, wait_s: float = 10.0) -> str:
        """The text of cell ``index``'s outputs (JupyterLab renders a cell when it is
        scrolled into view: it is, first; an output still rendering is waited for)."""
        cell = self.cell(index)
        cell.scroll_into_view_if_needed()
        outputs = cell.locator(".jp-OutputArea-output")
        deadline = time.monotonic() + wait_s
        while not "".join(outputs.all_inner_texts()).strip() and time.monotonic() < deadline:
            time.sleep(0.25)
        return "\n".join(outputs.all_inner_texts())

    def images(self, index: int, wait_s: float = 30.0) -> int:
        """How many pictures cell ``index``'s outputs show (a figure still rendering is
        waited for)."""
        cell = self.cell(index)
        cell.scroll_into_view_if_needed()
        pictures = cell.locator(".jp-OutputArea-output img")
        deadline = time.monotonic() + wait_s
        while pictures.count() == 0 and time.monotonic() < deadline:
            time.sleep(0.25)
        return pictures.count()

    def type_into(self, index: int, text: str) -> None:
        """Type ``text`` at the end of cell ``index``'s code, as a person edits it."""
        editor = self.cell(index).locator(".cm-content")
        editor.click()
        self.page.keyboard.press("Control+End")
        self.page.keyboard.type(text)
        self.page.keyboard.press("Escape")

    def kernel_value(self, expression: str) -> Any:
        """The value of ``expression`` in the notebook's kernel (a Python literal)."""
        reply = self._kernel_client().execute_interactive(
            "", silent=True, user_expressions={"value": f"repr({expression})"}, timeout=120
        )
        value = reply["content"]["user_expressions"]["value"]
        assert value["status"] == "ok", f"{expression}: {value.get('evalue')}"
        return ast.literal_eval(ast.literal_eval(value["data"]["text/plain"]))

    def kernel_until(self, expression: str, expected: Any, timeout_s: float = 20.0) -> Any:
        """Wait until the kernel's ``expression`` is ``expected`` (a widget's change reaches
        the kernel a moment after the click) and return it; the last value seen fails the
        test when it never is."""
        deadline = time.monotonic() + timeout_s
        while (value := self.kernel_value(expression)) != expected:
            assert time.monotonic() < deadline, f"{expression} is {value!r}, not {expected!r}"
            time.sleep(0.25)
        return value

    def type_readout(self, readout, text: str) -> None:
        """Type ``text`` into a slider's readout and press Enter, as a person sets a slider
        to an exact value."""
        readout.click()
        self.page.keyboard.press("Control+a")
        self.page.keyboard.type(text)
        self.page.keyboard.press("Enter")

    def _kernel_client(self):
        if self._kernel is None:
            from jupyter_client import BlockingKernelClient

            (session,) = [s for s in self.lab.api("sessions") if s["path"].endswith(self.name)]
            client = BlockingKernelClient(
                connection_file=str(self.lab.runtime / f"kernel-{session['kernel']['id']}.json")
            )
            client.load_connection_file()
            client.start_channels()
            client.wait_for_ready(timeout=60)
            self._kernel = client
        return self._kernel

    def save(self, showing: str) -> None:
        """Press the toolbar's Save and wait until the file on disk holds ``showing``."""
        self.page.locator(
            ".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Toolbar [data-command='docmanager:save']"
        ).click()
        deadline = time.monotonic() + 60
        while showing not in (self.lab.root / self.name).read_text("utf-8"):
            assert time.monotonic() < deadline, f"{self.name} was not saved"
            time.sleep(0.25)

    def close(self) -> None:
        if self._kernel is not None:
            self._kernel.stop_channels()
            self._kernel = None


@pytest.fixture
def open_notebook(browser, lab):
    """Open a notebook of the lab in a new browser page: ``open_notebook("00_...ipynb")``."""
    context = browser.new_context(viewport={"width": 1400, "height": 1000})
    opened: list[Notebook] = []

    def _open(name: str) -> Notebook:
        page = context.new_page()
        page.set_default_timeout(60_000)
        opened.append(Notebook(lab, page, name).open())
        return opened[-1]

    yield _open
    for book in opened:
        book.close()
    context.close()
