"""The procedure pages' parameter tables from one source: the shipped procedure YAMLs.

Each shipped procedure (``procedures/<kind>.yaml``, installed as ``sassi_bench.procedures``)
says what every key means in the comment beside it, continued on the comment lines below
it. The procedure pages under ``docs/procedures/`` carry a table of those keys between
``<!-- parameters: KIND [KEY ...] -->`` and ``<!-- end parameters -->`` markers (the keys,
when given, are the sections or keys the table shows), and
``tests/test_doc_parameters.py`` fails when a table differs from its YAML.

Run ``python benchmarks/procedure_parameters.py`` to rewrite every table after a
procedure YAML changed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
PROCEDURES = ROOT / "procedures"
PAGES = ROOT / "docs" / "procedures"

MARKER = re.compile(
    r"(<!-- parameters: (?P<kind>\w+)(?P<keys>(?: [\w.]+)*) -->\n)"
    r"(?P<body>.*?)(<!-- end parameters -->)",
    re.DOTALL,
)
_KEY = re.compile(r"^(?P<indent> *)(?P<key>[A-Za-z_]\w*):(?P<rest>.*)$")
_COMMENT = re.compile(r"^(?P<indent> *)#(?P<text>.*)$")
#: A null whose comment says it turns something off rather than leaving it to be derived.
_NULL_OFF = re.compile(r"null: (recorded only|none|off)\b")


@dataclass(frozen=True)
class Parameter:
    """One key of a procedure file: its dotted path, its value as written, its comment.

    ``value`` is empty for a section (a key holding further keys).
    """

    key: str
    value: str
    meaning: str
    section: bool = False


def _split_comment(rest: str) -> tuple[str, str]:
    """A key line's value and its comment (the shipped files quote no ``#``)."""
    value, _, comment = rest.partition("#")
    return value.strip(), comment.strip()


def parameters(path: Path) -> list[Parameter]:
    """Every key of a procedure YAML in file order, with the comment beside and below it.

    A comment line right under a key (no blank line between, indented deeper than the
    key) continues that key's comment; the file's opening comment describes the file and
    belongs to no key.

    >>> [p.key for p in parameters(PROCEDURES / "health_check.yaml")][:3]
    ['name', 'light', 'frames']
    """
    found: list[dict] = []
    stack: list[tuple[int, str]] = []  # (indent, key) of the sections around a line
    current: dict | None = None  # the key whose comment a comment line continues
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            current = None
            continue
        comment = _COMMENT.match(line)
        if comment:
            if current is not None and len(comment["indent"]) > current["indent"]:
                current["meaning"].append(comment["text"].strip())
            continue
        match = _KEY.match(line)
        if match is None:
            raise ValueError(
                f"{path.name}:{number}: not a 'key: value  # comment' line; the tables read "
                "block mappings with flow-style values only"
            )
        indent = len(match["indent"])
        while stack and stack[-1][0] >= indent:
            stack.pop()
        value, text = _split_comment(match["rest"])
        key = ".".join([*(k for _, k in stack), match["key"]])
        current = {"key": key, "value": value, "indent": indent, "meaning": [text] if text else []}
        found.append(current)
        if not value:
            stack.append((indent, match["key"]))
    return [
        Parameter(f["key"], f["value"], " ".join(f["meaning"]), section=not f["value"])
        for f in found
    ]


def _escape(text: str) -> str:
    """Text safe in a Markdown table cell (no HTML tags, emphasis or cell breaks)."""
    return re.sub(r"([\\<>*|])", r"\\\1", text)


def _shown(value: str, meaning: str) -> str:
    if value == "null":
        return "none" if _NULL_OFF.search(meaning) else "derived"
    return f"`{value}`"


def table(kind: str, keys: tuple[str, ...] = (), procedures: Path = PROCEDURES) -> str:
    """The Markdown table of procedure ``kind``'s keys (only ``keys`` and the keys under
    them, when given): key, shipped value, what it means."""
    rows = [
        p
        for p in parameters(procedures / f"{kind}.yaml")
        if p.key not in ("name", "source")
        and (not keys or any(p.key == k or p.key.startswith(k + ".") for k in keys))
    ]
    cells = [
        (p.key, "" if p.section else _shown(p.value, p.meaning), _escape(p.meaning))
        for p in rows
        if p.meaning or not p.section
    ]
    caption = f"Keys of `procedures/{kind}.yaml` as shipped"
    if any(value == "derived" for _, value, _ in cells):
        caption += (
            "; *derived*: `null` in the file, worked out from the rig when the run is planned"
            " (the meaning says how)"
        )
    # The container's class lets the site's CSS (docs/_static/tables.css) wrap long keys.
    lines = [caption + ".", "", ":::{container} parameter-table", ""]
    lines += ["| key | shipped value | what it means |", "| --- | --- | --- |"]
    lines += [f"| `{key}` | {value} | {meaning} |" for key, value, meaning in cells]
    return "\n".join([*lines, ":::"]) + "\n"


def blocks(text: str, procedures: Path = PROCEDURES) -> list[tuple[str, str, str]]:
    """Per marked block of ``text``: (its procedure, what it holds, what its YAML renders)."""
    return [
        (m["kind"], m["body"], table(m["kind"], tuple(m["keys"].split()), procedures))
        for m in MARKER.finditer(text)
    ]


def render(text: str, procedures: Path = PROCEDURES) -> str:
    """``text`` with every marked block rewritten from its procedure YAML."""
    return MARKER.sub(
        lambda m: m.group(1) + table(m["kind"], tuple(m["keys"].split()), procedures) + m.group(5),
        text,
    )


def loaded_keys(path: Path) -> dict[str, object]:
    """Every key of a procedure YAML as ``yaml`` loads it: dotted path -> value (a section
    maps to None)."""
    flat: dict[str, object] = {}

    def walk(mapping: dict, prefix: str) -> None:
        for key, value in mapping.items():
            if isinstance(value, dict):
                flat[prefix + key] = None
                walk(value, f"{prefix}{key}.")
            else:
                flat[prefix + key] = value

    walk(yaml.safe_load(path.read_text()), "")
    return flat


def main() -> None:
    for path in sorted(PAGES.glob("*.md")):
        text = path.read_text()
        if render(text) != text:
            path.write_text(render(text))
            print(f"rewrote the parameters of {path.relative_to(ROOT)} from procedures/")


if __name__ == "__main__":
    main()
