"""The pieces every self-contained HTML report of the workbench shares: its style sheet,
figures embedded as base64 PNGs, the JSON form of report data, tables of quality checks, and
writing a report's files without ever replacing an earlier report.

Examples
--------
>>> from matplotlib.figure import Figure
>>> figure_base64(Figure(figsize=(1, 1)))[:8]
'iVBORw0K'
"""

from __future__ import annotations

import base64
import html
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.plots.png import figure_png

__all__ = [
    "REPORT_CSS",
    "check_rows",
    "figure_base64",
    "image_tags",
    "jsonable",
    "page",
    "write_report_files",
]

#: The style sheet every HTML report of the workbench shares.
REPORT_CSS = """
body { font-family: system-ui, sans-serif; margin: 24px auto; max-width: 1320px; color: #222; }
h1 { font-size: 22px; margin-bottom: 4px; } h2 { font-size: 17px; margin-top: 28px; }
.verdict { display: inline-block; padding: 6px 16px; border-radius: 4px; color: white;
           font-weight: bold; font-size: 18px; }
.pass { background: #2e7d32; } .fail { background: #c62828; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: right; }
th { background: #f2f2f2; } td.l, th.l { text-align: left; }
td.bad, span.bad { color: #c62828; font-weight: bold; }
img { max-width: 100%; box-sizing: border-box; border: 1px solid #ddd; margin: 6px 0; }
.note { background: #fff8e1; border-left: 4px solid #f9a825; padding: 6px 12px; margin: 6px 0;
        font-size: 14px; }
.flex { display: flex; gap: 24px; flex-wrap: wrap; align-items: flex-start; }
.flex > div { min-width: 0; }
"""


def figure_base64(fig: Any, dpi: int = 100) -> str:
    """A matplotlib figure as base64 PNG text, for an ``<img src="data:...">``.

    Parameters
    ----------
    fig
        A matplotlib Figure.
    dpi
        Resolution of the PNG.

    Returns
    -------
    str
        ASCII base64 of the PNG bytes.

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> base64.b64decode(figure_base64(Figure(figsize=(1, 1))))[:4]
    b'\\x89PNG'
    """
    return base64.b64encode(figure_png(fig, dpi=dpi)).decode("ascii")


def image_tags(images: Mapping[str, str]) -> dict[str, str]:
    """``<img>`` elements for base64 PNGs, by name (the name is the alt text).

    Parameters
    ----------
    images
        Name -> base64 PNG (e.g. from :func:`figure_base64`).

    Returns
    -------
    dict
        Name -> ``<img>`` element with the PNG inline as a data URI.

    Examples
    --------
    >>> image_tags({"spectra": "AAAA"})["spectra"]
    '<img alt="spectra" src="data:image/png;base64,AAAA">'
    """
    return {
        k: f'<img alt="{html.escape(k)}" src="data:image/png;base64,{v}">'
        for k, v in images.items()
    }


def jsonable(value: Any) -> Any:
    """``value`` with NumPy arrays and scalars as Python lists and numbers, mappings with
    string keys, and non-finite floats as None (JSON has no NaN), for a report's JSON.

    Parameters
    ----------
    value
        Nested mappings, lists, tuples, arrays and scalars.

    Returns
    -------
    object
        The same structure made of dicts, lists, str, int, float, bool and None.

    Examples
    --------
    >>> jsonable({"a": np.array([1.5, np.nan]), 2: (np.int64(3),)})
    {'a': [1.5, None], '2': [3]}
    """
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def check_rows(
    checks: Sequence[Mapping[str, Any]], fmt: str, floors: Mapping[str, float] | None = None
) -> list[list[str]]:
    """Rows of a table of quality checks (their manifest form): name, value, tolerance and
    result (a failure in a ``bad`` cell); with ``floors``, a noise-floor column after the value.

    Parameters
    ----------
    checks
        ``QualityCheck.to_manifest()`` dictionaries.
    fmt
        Format of the values and floors (e.g. ``".3f"``).
    floors
        Noise floor by check name, where one is known.

    Returns
    -------
    list of list of str
        Rows for :func:`sassi_bench._shared.tables.html_table`.

    Examples
    --------
    >>> check = {"name": "rms", "value": 0.021, "tolerance": 0.05, "unit": "px",
    ...          "comparison": "<=", "passed": True}
    >>> check_rows([check], ".3f")
    [['<td class="l">rms</td>', '0.021 px', '&lt;= 0.05 px', 'pass']]
    """
    from sassi_bench.bundle.quality import format_tolerance, unit_suffix

    esc = html.escape
    rows = []
    for c in checks:
        unit = esc(unit_suffix(c["unit"]))
        row = [f'<td class="l">{esc(str(c["name"]))}</td>', f"{c['value']:{fmt}}{unit}"]
        if floors is not None:
            floor = floors.get(str(c["name"]))
            row.append("" if floor is None else f"{floor:{fmt}}{unit}")
        row += [
            f"{esc(str(c.get('comparison', '<=')))} {format_tolerance(c['tolerance'])}{unit}",
            "pass" if c["passed"] else '<td class="bad">FAIL</td>',
        ]
        rows.append(row)
    return rows


def page(title: str, body: str) -> str:
    """A whole HTML document with the reports' style sheet.

    Parameters
    ----------
    title
        The document's title (plain text; escaped here).
    body
        The content of ``<body>`` (HTML).

    Returns
    -------
    str

    Examples
    --------
    >>> page("A & B", "<p>hi</p>").splitlines()[2]
    '<title>A &amp; B</title>'
    """
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>{html.escape(title)}</title>
<style>{REPORT_CSS}</style></head><body>
{body}
</body></html>
"""


def write_report_files(
    folder: str | os.PathLike[str], files: Mapping[str, str], step: str
) -> list[Path]:
    """Write a report's files (name -> text) into ``folder``, each atomically, never over
    an earlier report: if any of them exists, nothing is written.

    Raises
    ------
    ProcedureError
        When one of the files is already there.

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> [p.name for p in write_report_files(folder, {"r.html": "<p>1</p>"}, "demo")]
    ['r.html']
    >>> write_report_files(folder, {"r.html": "<p>2</p>"}, "demo")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: demo: .../r.html already exists. Fix: ...
    """
    target = Path(folder)
    paths = [target / name for name in files]
    taken = [p for p in paths if p.exists()]
    if taken:
        raise ProcedureError(
            step_error(
                step,
                f"{taken[0]} already exists",
                "write the report into another folder, or move the earlier one away: "
                "reports are never replaced",
            )
        )
    target.mkdir(parents=True, exist_ok=True)
    for path, text in zip(paths, files.values(), strict=True):
        atomic_write_text(path, text, overwrite=False)
    return paths
