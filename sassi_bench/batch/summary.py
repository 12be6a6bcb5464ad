"""The batch summary: one row per session, as CSV and as one self-contained HTML page."""

from __future__ import annotations

import csv
import html
import io
from collections.abc import Sequence
from pathlib import Path

from sassi_bench._shared.tables import html_table
from sassi_bench.batch.tasks import SessionResult
from sassi_bench.plots.html import page

__all__ = ["summary_csv", "summary_html", "summary_rows"]

#: Metrics shown per kind, with their column heading.
METRICS = {"mean_de00": "mean dE00", "max_de00": "max dE00", "passed": "passed"}


def summary_rows(results: Sequence[SessionResult]) -> tuple[list[str], list[list[str]]]:
    """Header and rows: session, status, frames, time, the metrics any session has, output
    and error.

    Parameters
    ----------
    results
        One result per session.

    Returns
    -------
    header : list of str
        The column names.
    rows : list of list of str
        One row of text cells per result, in order (floats to 3 decimals, time to 2).

    Examples
    --------
    >>> header, rows = summary_rows([SessionResult("scan-1", "done", 20, 1.234, "/o/scan-1.nc")])
    >>> header[:4], rows[0][:4]
    (['session', 'status', 'frames', 'time_s'], ['scan-1', 'done', '20', '1.23'])
    """
    metrics = [m for m in METRICS if any(m in r.metrics for r in results)]
    header = ["session", "status", "frames", "time_s", *metrics, "output", "error"]
    rows = []
    for r in results:
        values = []
        for m in metrics:
            value = r.metrics.get(m, "")
            values.append(f"{value:.3f}" if isinstance(value, float) else str(value))
        rows.append(
            [r.session, r.status, str(r.frames), f"{r.seconds:.2f}", *values, r.output, r.error]
        )
    return header, rows


def summary_csv(results: Sequence[SessionResult], path: str | Path) -> Path:
    """Write the summary table as CSV.

    Parameters
    ----------
    results
        One result per session.
    path
        The CSV file to write.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "batch.csv"
    >>> summary_csv([SessionResult("scan-1", "done", 20, 1.2)], path).read_text().splitlines()[1]
    'scan-1,done,20,1.20,,'
    """
    header, rows = summary_rows(results)
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(header)
    writer.writerows(rows)
    path = Path(path)
    path.write_text(buffer.getvalue())
    return path


def summary_html(
    results: Sequence[SessionResult], path: str | Path, *, title: str, facts: Sequence[str] = ()
) -> Path:
    """Write the summary table as one self-contained HTML page (failed rows in red; outputs
    by file name, their folder is the page's).

    Parameters
    ----------
    results
        One result per session.
    path
        The HTML file to write.
    title
        The page's title and heading.
    facts
        Sentences listed under the heading (cluster, bundle, ...).

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    Not run here (it needs captured sessions)::

        summary_html([SessionResult("scan-1", "done", 20, 1.2, "/o/scan-1.nc")],
                     "batch.html", title="batch assemble")
    """
    header, rows = summary_rows(results)
    names = [html.escape(METRICS.get(h, h.replace("_s", " (s)"))) for h in header]
    out = header.index("output")
    cells = []
    for row in rows:
        cls = "l bad" if row[1] == "failed" else "l"
        row = [*row[:out], Path(row[out]).name if row[out] else "", *row[out + 1 :]]
        cells.append([f'<td class="{cls}">{html.escape(c)}</td>' for c in row])
    failed = sum(r.status == "failed" for r in results)
    counts = {s: sum(r.status == s for r in results) for s in ("done", "skipped", "failed")}
    verdict = "fail" if failed else "pass"
    text = ", ".join(f"{n} {s}" for s, n in counts.items())
    items = "".join(f"<li>{html.escape(f)}</li>" for f in facts)
    body = f"""<h1>{html.escape(title)}</h1>
<p><span class="verdict {verdict}">{len(results)} sessions: {html.escape(text)}</span></p>
<ul>{items}</ul>
{html_table(names, cells, left=len(names))}"""
    path = Path(path)
    path.write_text(page(title, body))
    return path
