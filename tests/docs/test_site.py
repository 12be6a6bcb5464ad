"""The documentation site builds from ``docs/`` with warnings as errors, every local link
of every page resolves, the guided notebooks' pages show the outputs of their run, and
its front page renders in headless Chromium."""

from __future__ import annotations

import subprocess
import sys
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest

from sassi_bench.plots.screenshot import chromium_path, screenshot

pytest.importorskip("sphinx", reason="Sphinx is not installed: pip install -e '.[docs]'")
pytest.importorskip("pydata_sphinx_theme", reason="the docs extra is not installed")
pytest.importorskip("myst_nb", reason="the docs extra is not installed")

DOCS = Path(__file__).parents[2] / "docs"
NOTEBOOKS = DOCS.parent / "notebooks"
RERUN = "run `python benchmarks/render_notebooks.py` after changing a notebook's code"

#: Pages the site must have: the user guide, one page per procedure, the maintainers'
#: map, a notebook and the API reference of the bundle.
REQUIRED = [
    "index.html",
    "getting_started.html",
    *(
        f"procedures/{p}.html"
        for p in ("calibrate", "spectral", "scan", "guide", "macbeth", "health_check")
    ),
    "procedures/snapshot.html",
    "procedures/batch.html",
    "describing_your_rig.html",
    "real_bench.html",
    "bundle_api.html",
    "accuracy.html",
    "performance.html",
    "guided_notebooks.html",
    "_notebooks/00_quickstart.html",
    "api.html",
    "_autosummary/sassi_bench.bundle.html",
    "ARCHITECTURE.html",
    "notes/index.html",
    "changelog.html",
]


class _Links(HTMLParser):
    """The href and src of every element of a page, and its title and nav text."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.title = ""
        self._in_title = False

    def handle_starttag(self, tag, attrs):
        for name, value in attrs:
            if name in ("href", "src") and value:
                self.links.append(value)
        self._in_title = tag == "title"

    def handle_endtag(self, tag):
        self._in_title = False

    def handle_data(self, data):
        if self._in_title:
            self.title += data


class _Outputs(HTMLParser):
    """The images and the text inside a notebook page's cell outputs."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.text: list[str] = []
        self.outputs = 0
        self._depth = 0  # open divs inside the current cell output, 0: outside

    def handle_starttag(self, tag, attrs):
        found = dict(attrs)
        if self._depth == 0 and tag == "div" and "cell_output" in (found.get("class") or ""):
            self.outputs += 1
            self._depth = 1
        elif self._depth and tag == "div":
            self._depth += 1
        if self._depth and tag == "img":
            self.images.append(found.get("src") or "")

    def handle_endtag(self, tag):
        if self._depth and tag == "div":
            self._depth -= 1

    def handle_data(self, data):
        if self._depth and data.strip():
            self.text.append(data)


def _local(link: str) -> str | None:
    """The file part of a link within the site, or None for links out of it."""
    parsed = urlparse(link)
    if parsed.scheme or parsed.netloc or link.startswith(("#", "mailto:", "javascript:")):
        return None
    return unquote(parsed.path) or None


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The built site (``sphinx-build -W``), with its build time."""
    out = tmp_path_factory.mktemp("site")
    command = [
        sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
        "-d", str(out / ".doctrees"), str(DOCS), str(out / "html"),
    ]  # fmt: skip
    start = time.perf_counter()
    # About 80 s of CPU; a heavily loaded machine stretched it to 15 minutes of wall time.
    done = subprocess.run(command, capture_output=True, text=True, timeout=2400, check=False)
    seconds = time.perf_counter() - start
    assert done.returncode == 0, f"sphinx-build -W failed:\n{done.stderr[-6000:]}"
    html = out / "html"
    # The pages (the theme copies a Jinja template into _static: not a page).
    pages = sorted(p for p in html.rglob("*.html") if "_static" not in p.relative_to(html).parts)
    print(f"\ndocumentation site: {len(pages)} pages built in {seconds:.0f} s")
    return html, pages


def test_the_site_has_every_page(site):
    html, pages = site
    missing = [name for name in REQUIRED if not (html / name).is_file()]
    assert not missing
    # One API page per module, not only the packages.
    assert sum(1 for p in pages if p.parent.name == "_autosummary") > 50


def test_every_local_link_resolves(site):
    html, pages = site
    broken = []
    for page in pages:
        parser = _Links()
        parser.feed(page.read_text())
        for link in parser.links:
            path = _local(link)
            if path is not None and not (page.parent / path).exists():
                broken.append(f"{page.relative_to(html)} -> {link}")
    assert not broken, broken[:20]


def test_the_pages_quote_the_data_files(site):
    html, _ = site
    accuracy = (html / "accuracy.html").read_text()
    assert "lamp-anchored: all five at their true lines" in accuracy
    assert "benchmarks/accuracy_table.py</span>" in accuracy  # the command, as code


def test_every_notebook_page_shows_the_outputs_of_its_run(site):
    """Each guided notebook's page shows what its run printed and, where the notebook shows
    figures, the figures (``benchmarks/render_notebooks.py``; the build executes nothing)."""
    html, _ = site
    for notebook in sorted(NOTEBOOKS.glob("*.ipynb")):
        page = html / "_notebooks" / f"{notebook.stem}.html"
        parser = _Outputs()
        parser.feed(page.read_text())
        assert parser.outputs, f"{page.name} shows no outputs: {RERUN}"
        assert len("".join(parser.text)) > 100, page.name
        if "show(" in notebook.read_text():
            assert parser.images, f"{page.name} shows no figure: {RERUN}"
            for src in parser.images:  # files the build copied, or widgets' own data
                assert src.startswith("data:image/") or (page.parent / src).is_file(), src
    # Printed results and the decision widgets' static copies, not their Python repr.
    quickstart = (html / "_notebooks" / "00_quickstart.html").read_text()
    assert "published sim/v0001" in quickstart and "wavelength bins" in quickstart
    assert "<b>[accept]</b>" in quickstart and "stopped after" in quickstart
    assert "spectral-sweep: 100%" in quickstart  # a progress bar, as it ended
    assert "/tmp/" not in quickstart


def test_the_front_page_renders_in_chromium(site, tmp_path):
    html, _ = site
    front = html / "index.html"
    browser = chromium_path()
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium)")
    dom = subprocess.run(
        [browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--disable-background-networking", "--dump-dom", front.as_uri()],
        capture_output=True, text=True, timeout=120, check=True,
    ).stdout  # fmt: skip
    parser = _Links()
    parser.feed(dom)
    assert "sassi_bench" in parser.title
    # The navigation bar, rendered, leads to the user guide and the API reference.
    assert 'class="bd-header' in dom and "navbar" in dom
    assert "getting_started.html" in dom and "api.html" in dom
    png = screenshot(front, tmp_path / "front.png", width=1280, height=1000)
    import cv2

    image = cv2.imread(str(png))
    assert image.shape[:2] == (1000, 1280)
    # Not a blank page: text and the figure drew dark pixels over a good part of it.
    assert (image < 128).any(axis=2).mean() > 0.01
    assert np.std(image) > 20
