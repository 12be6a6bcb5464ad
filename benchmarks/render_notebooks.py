"""Run every guided notebook on the virtual bench and keep the outputs for the docs site.

The notebooks of ``notebooks/`` are committed without outputs, and the documentation
build never executes anything. This script runs them, in their numbered order, in one
fresh temporary data root on the ``sim`` rig (later notebooks use the sessions and
bundles of earlier ones, as in a lab), with nbclient, and writes the executed copies to
``docs/_data/notebooks/`` with ``provenance.json`` (the date, the machine, the command,
each notebook's wall time and the settings it ran with). ``docs/conf.py`` shows a
notebook's executed copy while its code cells are the notebook's own, else the bare
notebook.

The run injects one setting after the cell tagged ``parameters`` (the line is kept, so
the page shows what ran): the data root ``calib_data`` relative to the kernel's working
folder (the temporary root, so the printed paths read ``calib_data/...``). Every other
parameter is the notebook's default. For a static page:

- progress bars are tqdm's text bars (the widget bars of JupyterLab need a live kernel),
  their carriage-return updates collapsed to the final line;
- a widget's output keeps the static HTML copy it displays with
  (:func:`sassi_bench.notebook.widgets.static_html`), or gets one of its final state (the
  live view), and the widget state is dropped;
- a figure made of camera frames is kept as JPEG when that is under half its PNG's size,
  and the images of a widget's static copy are at most :data:`MAX_IMAGE_PX` wide.

Run: ``python benchmarks/render_notebooks.py [--only 00_quickstart ...] [--keep DIR]``
(``--only`` renders those notebooks after running the ones before them unsaved).
"""

from __future__ import annotations

import argparse
import base64
import datetime
import json
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import nbformat
from figures import machine

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
OUT = ROOT / "docs" / "_data" / "notebooks"

#: The data root the notebooks use, relative to the kernel's working folder.
DATA = "calib_data"

#: The settings added after every notebook's parameters cell.
INJECTED: dict[str, object] = {"data": DATA}

#: Embedded images (in widgets' static HTML) are scaled to at most this width, px.
MAX_IMAGE_PX = 640

#: The JPEG quality of figures and images kept as JPEG.
JPEG_QUALITY = 88

WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"

#: Under the static copy of a widget's final state.
STATIC_NOTE = '<div style="color:#666;font-size:smaller">(as it was when the notebook ended)</div>'

#: Run in the kernel before the notebook: tqdm's text bars, which a static page can show.
PREAMBLE = """\
import tqdm.auto, tqdm.std
tqdm.auto.tqdm, tqdm.auto.trange = tqdm.std.tqdm, tqdm.std.trange
"""

#: Run in the kernel after the notebook: the static HTML of the widgets given by model id.
STATIC_WIDGETS = """\
import json as _json
from ipywidgets.widgets.widget import _instances as _widgets
from sassi_bench.notebook.widgets import static_html as _static_html
print(_json.dumps({{m: _static_html(_widgets[m]) for m in {ids!r} if m in _widgets}}))
"""


def _inject(book: nbformat.NotebookNode, settings: dict[str, object]) -> None:
    cells = [c for c in book.cells if "parameters" in c.metadata.get("tags", [])]
    if len(cells) != 1:
        raise SystemExit("a notebook needs exactly one cell tagged 'parameters'")
    lines = [f"{k} = {v!r}" for k, v in settings.items()]
    cells[0].source += (
        "\n\n# The documentation's run (benchmarks/render_notebooks.py):\n" + "\n".join(lines)
    )


def _collapse_stream(text: str) -> str:
    """What a terminal shows of ``text``: each line after its last carriage return."""
    lines = [line.rstrip("\r").rsplit("\r", 1)[-1] for line in text.split("\n")]
    return "\n".join(lines)


def _compact(png: bytes, max_width: int | None = None) -> tuple[str, bytes]:
    """An image's type and bytes for the page: scaled down to ``max_width`` px when wider,
    and as JPEG when that is under half the PNG's size (a camera frame or a figure made
    of them stores badly as PNG; a line plot stays PNG)."""
    import cv2
    import numpy as np

    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        return "png", png
    if max_width is not None and image.shape[1] > max_width:
        height = round(image.shape[0] * max_width / image.shape[1])
        image = cv2.resize(image, (max_width, height), interpolation=cv2.INTER_AREA)
        png = cv2.imencode(".png", image, [cv2.IMWRITE_PNG_COMPRESSION, 9])[1].tobytes()
    jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])[1].tobytes()
    return ("jpeg", jpeg) if 2 * len(jpeg) < len(png) else ("png", png)


def _shrink_images(html: str) -> str:
    """The PNG data URIs of ``html`` (a widget's images) made compact (:func:`_compact`),
    at most :data:`MAX_IMAGE_PX` wide."""

    def shrink(match: re.Match) -> str:
        kind, data = _compact(base64.b64decode(match.group(1)), MAX_IMAGE_PX)
        return f"data:image/{kind};base64,{base64.b64encode(data).decode()}"

    return re.sub(r"data:image/png;base64,([A-Za-z0-9+/=]+)", shrink, html)


def _neutral(text: str, root: Path) -> str:
    """``text`` with the temporary root's path made relative (``calib_data/...``)."""
    for prefix in {str(root), str(root.resolve())}:
        text = text.replace(prefix + os.sep, "").replace(prefix, ".")
    return text


def _tidy(book: nbformat.NotebookNode, root: Path, static: dict[str, str]) -> None:
    """Make the executed notebook fit a static page (see the module docstring)."""
    book.metadata.pop("widgets", None)
    for cell in book.cells:
        if cell.cell_type != "code":
            continue
        cell.metadata.pop("execution", None)
        outputs: list = []
        for output in cell.outputs:
            if output.output_type == "stream":
                last = outputs[-1] if outputs else None
                if last is not None and last.output_type == "stream" and last.name == output.name:
                    last.text += output.text
                    continue
                outputs.append(output)
                continue
            data = output.get("data", {})
            if "image/png" in data:
                kind, image = _compact(base64.b64decode(data["image/png"]))
                if kind == "jpeg":
                    del data["image/png"]
                    data["image/jpeg"] = base64.b64encode(image).decode()
            if WIDGET_VIEW in data:
                model = data.pop(WIDGET_VIEW).get("model_id")
                if "text/html" not in data and model in static:
                    data["text/html"] = static[model] + STATIC_NOTE
            outputs.append(output)
        for output in outputs:
            if output.output_type == "stream":
                output.text = _neutral(_collapse_stream(output.text), root)
            for mime, value in output.get("data", {}).items():
                if mime.startswith("text/") and isinstance(value, str):
                    value = _neutral(value, root)
                    output.data[mime] = _shrink_images(value) if mime == "text/html" else value
            if output.output_type == "error":
                output.traceback = [_neutral(line, root) for line in output.traceback]
        cell.outputs = outputs


def _helper(client, book: nbformat.NotebookNode, source: str) -> str:
    """Run ``source`` in the notebook's kernel, not kept in the notebook; what it printed."""
    cell = nbformat.v4.new_code_cell(source)
    book.cells.append(cell)
    try:
        client.execute_cell(cell, len(book.cells) - 1)
    finally:
        book.cells.pop()
    return "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")


def render(name: str, root: Path) -> tuple[nbformat.NotebookNode, float]:
    """Execute ``notebooks/<name>`` in the folder ``root`` (whose ``calib_data`` is the data
    root); the executed notebook, tidied, and its wall time in seconds."""
    import nbclient

    book = nbformat.read(NOTEBOOKS / name, as_version=4)
    _inject(book, INJECTED)
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env.pop("SASSI_BENCH_DATA", None)
    client = nbclient.NotebookClient(
        book, timeout=3600, kernel_name="python3", resources={"metadata": {"path": str(root)}}
    )
    start = time.perf_counter()
    with client.setup_kernel(env=env):
        _helper(client, book, PREAMBLE)
        for index, cell in enumerate(book.cells):
            client.execute_cell(cell, index)
        ids = [
            o.data[WIDGET_VIEW]["model_id"]
            for c in book.cells
            if c.cell_type == "code"
            for o in c.outputs
            if WIDGET_VIEW in o.get("data", {}) and "text/html" not in o.data
        ]
        static: dict[str, str] = {}
        if ids:
            said = _helper(client, book, STATIC_WIDGETS.format(ids=ids))
            static = json.loads(said)
    seconds = time.perf_counter() - start
    _tidy(book, root, static)
    return book, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="+", help="notebook names (stems) to write")
    parser.add_argument("--keep", help="run in this folder and keep it (default: temporary)")
    args = parser.parse_args()
    names = sorted(p.name for p in NOTEBOOKS.glob("*.ipynb"))
    wanted = set(names) if not args.only else {f"{Path(n).stem}.ipynb" for n in args.only}
    last = max(names.index(n) for n in wanted)
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="render-"))
    root.mkdir(parents=True, exist_ok=True)
    OUT.mkdir(parents=True, exist_ok=True)
    record_path = OUT / "provenance.json"
    record = json.loads(record_path.read_text()) if record_path.exists() else {}
    record.setdefault("notebooks", {})
    total = 0.0
    try:
        for name in names[: last + 1]:
            book, seconds = render(name, root)
            total += seconds
            print(f"{name}: {seconds:.0f} s", flush=True)
            if name in wanted:
                nbformat.write(book, OUT / name)
                record["notebooks"][name] = {
                    "date": datetime.date.today().isoformat(),
                    "seconds": round(seconds, 1),
                    "settings": {k: repr(v) for k, v in INJECTED.items()},
                }
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    record.update(
        title="The guided notebooks as executed for the documentation site",
        rig="sim",
        date=datetime.date.today().isoformat(),
        machine=machine(),
        command="python " + " ".join([os.path.relpath(sys.argv[0], ROOT), *sys.argv[1:]]),
        seconds=round(total, 1),
    )
    record["notebooks"] = dict(sorted(record["notebooks"].items()))
    record_path.write_text(json.dumps(record, indent=1, ensure_ascii=False) + "\n")
    size = sum(p.stat().st_size for p in OUT.iterdir())
    print(f"all: {total:.0f} s; {OUT.relative_to(ROOT)}: {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
