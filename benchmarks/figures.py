"""The documentation's figures from one source: the data files the benchmarks write.

A benchmark that measures what the documentation quotes writes it to
``docs/_data/<name>.json``: a table (row labels, one column per rig or setting) and, for
every column, the date, the machine and the command that measured it. The README and the
user pages under ``docs/`` carry copies between ``<!-- figures: NAME [VIEW] -->`` and
``<!-- end figures -->`` markers, and ``tests/test_doc_figures.py`` fails when a copy, or
a dB or dE00 figure quoted anywhere in those files, differs from its data file.

Run ``python benchmarks/figures.py`` to rewrite every copy after a benchmark updated a
data file.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "docs" / "_data"

#: Views of the data files a marked block may name (``<!-- figures: NAME VIEW -->``): the
#: columns and rows it shows. A block without a view shows the whole table and where each
#: column comes from.
VIEWS = {
    "headline": {
        "keys": ("sim", "as-built-all", "all-deviations", "sim-achromat", "sim-singlet"),
        "rows": (
            "all checks pass",
            "correspondences vs truth (worst laser RMS)",
            "laser line fitted at an estimate",
            "wavelength map vs truth (RMS / max)",
            "blur width vs truth (max over the field, 420-690 nm)",
            "guide homography vs truth (RMS over the SLM)",
            "response vs truth (max, 410-640 nm)",
            "Macbeth mean dE00 / spectral angle",
            "chart scan vs truth: PSNR / mean angle",
        ),
    },
}

MARKER = re.compile(
    r"(<!-- figures: (?P<name>[\w-]+)(?: (?P<view>[a-z]+))?(?: \([^\n]*\))? -->\n)"
    r"(?P<body>.*?)(<!-- end figures -->)",
    re.DOTALL,
)


def machine() -> str:
    """A one-line description of the machine a benchmark runs on, with its load (wall
    times on a loaded machine are inflated; CPU times and ratios much less)."""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    return (
        f"{platform.system()} {platform.machine()}, {os.cpu_count()} CPUs, Python "
        f"{platform.python_version()}, load average {load} as it ended"
    )


def load(name: str, data: Path = DATA) -> dict:
    """The data file ``docs/_data/<name>.json``."""
    return json.loads((Path(data) / f"{name}.json").read_text())


def update_columns(
    name: str,
    title: str,
    rows: list[str],
    columns: list[dict],
    row_label: str = "",
    code_keys: bool = False,
    replace: bool = False,
    data: Path = DATA,
) -> Path:
    """Write or merge ``columns`` (each ``{"key": ..., "values": {row: text}}``) into
    ``docs/_data/<name>.json``, stamping each with today's date, this machine and the
    command line that ran; columns of other keys already in the file are kept.
    ``row_label`` heads the rows' column; ``code_keys`` sets the column keys as code
    (rig names); ``replace`` drops the columns already in the file (a table from one run)."""
    path = Path(data) / f"{name}.json"
    table = json.loads(path.read_text()) if path.exists() and not replace else {"columns": []}
    stamp = {
        "date": datetime.date.today().isoformat(),
        "machine": machine(),
        "command": "python " + " ".join([os.path.relpath(sys.argv[0], ROOT), *sys.argv[1:]]),
        "source": "measured",
    }
    new = {c["key"]: {"key": c["key"], **stamp, "values": c["values"]} for c in columns}
    kept = [new.pop(c["key"], c) for c in table["columns"]]
    table.update(title=title, row_label=row_label, code_keys=code_keys, rows=rows)
    table["columns"] = kept + list(new.values())
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(table, indent=1, ensure_ascii=False) + "\n")
    return path


def markdown(
    table: dict, keys: tuple[str, ...] | None = None, rows: tuple[str, ...] | None = None
) -> str:
    """A data file's table as Markdown, one column per key (all when ``keys`` is None),
    its ``rows`` (all when None); a figure a column lacks is a dash, a row none has is
    left out."""
    columns = [c for c in table["columns"] if keys is None or c["key"] in keys]
    if keys is not None:
        columns.sort(key=lambda c: keys.index(c["key"]))
    quote = "`" if table.get("code_keys") else ""
    lines = [
        f"| {table.get('row_label', '')} | ".replace("|  |", "| |")
        + " | ".join(f"{quote}{c['key']}{quote}" for c in columns)
        + " |",
        "| --- |" + " --- |" * len(columns),
    ]
    for row in table["rows"]:
        if rows is not None and row not in rows:
            continue
        cells = [c["values"].get(row) or "-" for c in columns]
        if any(cell != "-" for cell in cells):
            lines.append(f"| {row} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def provenance(table: dict) -> str:
    """One line per distinct (date, machine, command, source) of a table's columns."""
    seen: dict[tuple, list[str]] = {}
    for c in table["columns"]:
        key = (c["date"], c["machine"], c["command"], c.get("source", "measured"))
        seen.setdefault(key, []).append(c["key"])
    if len(seen) == 1:
        (date, mach, command, source), _ = next(iter(seen.items()))
        seen = {(date, mach, command, source): ["every column"]}
    return "\n".join(
        f"- {', '.join(k if k == 'every column' else f'`{k}`' for k in keys)}: "
        f"`{command}`, {date}, {mach}" + ("" if source == "measured" else f" ({source})")
        for (date, mach, command, source), keys in seen.items()
    )


def block(name: str, view: str | None = None, data: Path = DATA) -> str:
    """What a marked block of data file ``name`` holds: its ``view`` of the table, or the
    whole table and where each column comes from."""
    table = load(name, data)
    if view is not None:
        return markdown(table, **VIEWS[view])
    return markdown(table) + "\n" + provenance(table) + "\n"


def marked_files(root: Path = ROOT) -> list[Path]:
    """The files whose marked blocks quote the data files: the README and the user pages
    (the dated notes keep the figures of their day)."""
    pages = sorted(p for p in (root / "docs").rglob("*.md") if not _excluded(p, root))
    return [root / "README.md", *pages]


def _excluded(page: Path, root: Path) -> bool:
    parts = page.relative_to(root / "docs").parts
    return parts[0] in ("notes", "_build", "_generated") or parts[0].startswith(".")


def blocks(text: str, data: Path = DATA) -> list[tuple[str, str, str]]:
    """Per marked block of ``text``: (its name, what it holds, what its data file renders)."""
    return [
        (m["name"], m["body"], block(m["name"], m["view"], data)) for m in MARKER.finditer(text)
    ]


def render(text: str, data: Path = DATA) -> str:
    """``text`` with every marked block rewritten from its data file."""
    return MARKER.sub(lambda m: m.group(1) + block(m["name"], m["view"], data) + m.group(5), text)


def main() -> None:
    for path in marked_files():
        text = path.read_text()
        if render(text) != text:
            path.write_text(render(text))
            print(f"rewrote the figures of {path.relative_to(ROOT)} from {DATA.relative_to(ROOT)}/")


if __name__ == "__main__":
    main()
