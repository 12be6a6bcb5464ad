"""Tables as text (terminal listings) and as HTML (reports and notebooks).

Examples
--------
>>> print(text_table(["RIG", "VERSION"], [["sim", "v0001"], ["sim-prototype", "v0012"]]))
RIG            VERSION
sim            v0001
sim-prototype  v0012
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["html_table", "text_table"]


def text_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Columns padded to their widest cell, two spaces apart, no trailing blanks.

    Parameters
    ----------
    header
        Column headings.
    rows
        Rows of cells, each as long as ``header``.

    Returns
    -------
    str
        The table, one line per row, the header first.

    Examples
    --------
    >>> text_table(["A", "B"], [["long cell", "x"]]).splitlines()
    ['A          B', 'long cell  x']
    """
    table = [list(header), *(list(row) for row in rows)]
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in table
    )


def html_table(header: Sequence[str], rows: Sequence[Sequence[str]], left: int = 1) -> str:
    """An HTML ``<table>`` whose first ``left`` columns are left-aligned (class ``l``).

    Cells are HTML fragments, escaped by the caller; a cell that starts with ``<td`` is
    taken as a whole cell, so a caller can set its class (``<td class="bad">FAIL</td>``).
    The classes match the reports' style sheet (:data:`sassi_bench.plots.html.REPORT_CSS`).

    Parameters
    ----------
    header
        Column headings (HTML).
    rows
        Rows of cells (HTML fragments or whole ``<td>`` cells).
    left
        How many leading columns are text (left-aligned); numbers are right-aligned.

    Returns
    -------
    str
        One line of HTML.

    Examples
    --------
    >>> html_table(["check", "value"], [["rms", '<td class="bad">0.9</td>']])
    '<table><tr><th class="l">check</th><th class="">value</th></tr><tr><td>rms</td><td \
class="bad">0.9</td></table>'
    """
    head = "".join(f'<th class="{"l" if i < left else ""}">{h}</th>' for i, h in enumerate(header))
    body = "".join(
        "<tr>" + "".join(cell if cell.startswith("<td") else f"<td>{cell}</td>" for cell in row)
        for row in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"
