"""Decision widgets for the guided notebooks.

Every function returns an ipywidgets control whose initial value is the sensible default
(the procedure's choice, or "accept" exactly when every tolerance passed). A notebook
reads ``.value`` in a later cell, so a run without a person goes on with the defaults
and a person can change them before running the rest; :func:`accepted` reads an
accept/reject choice, and a notebook publishes or saves only what was accepted.

Each control also carries a static HTML rendering of itself (:func:`static_html`) in its
display output, so an executed notebook opened later without a kernel (or untrusted, or
in a viewer that does not run widgets) shows the table, the choice and the values as
they were, instead of the widget's Python repr.
"""

from __future__ import annotations

import base64
import functools
import html
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

__all__ = [
    "accept_checks",
    "accepted",
    "chart_corners",
    "checks_table",
    "excluded_region",
    "pick_chart_corners",
    "pick_excluded_region",
    "pick_exposure",
    "pick_lasers",
    "show_png",
    "static_html",
]


def static_html(widget: Any) -> str:
    """A static HTML rendering of a widget (and its children) with its current values.

    Examples
    --------
    >>> import ipywidgets as widgets
    >>> static_html(widgets.ToggleButtons(options=["accept", "reject"], value="reject"))
    '<div>accept <b>[reject]</b></div>'
    >>> print(static_html(widgets.HBox([widgets.Button(description="Stop")])))
    <div style="display:flex;flex-wrap:wrap;gap:1em"><div><button disabled>Stop</button></div></div>
    """
    import ipywidgets as widgets

    def label(text: str) -> str:
        return f"{html.escape(text)}: " if text else ""

    if isinstance(widget, widgets.Box):
        # A row stays a row (wrapping on a narrow page); other boxes stack their children.
        row = isinstance(widget, widgets.HBox)
        style = ' style="display:flex;flex-wrap:wrap;gap:1em"' if row else ""
        return f"<div{style}>" + "".join(static_html(c) for c in widget.children) + "</div>"
    if isinstance(widget, widgets.HTML):
        return f"<div>{widget.value}</div>"
    if isinstance(widget, widgets.Image):
        data = base64.b64encode(bytes(widget.value)).decode("ascii")
        width = (
            f' width="{html.escape(str(widget.width))}"'
            if widget.width
            else f' style="width:{html.escape(widget.layout.width)}"'
            if widget.layout.width
            else ""
        )
        return f'<img src="data:image/{widget.format};base64,{data}"{width}>'
    if isinstance(widget, (widgets.ToggleButtons, widgets.Dropdown, widgets.RadioButtons)):
        marks = [
            f"<b>[{html.escape(str(name))}]</b>" if value == widget.value else html.escape(name)
            for name, value in zip(widget._options_labels, widget._options_values, strict=True)
        ]
        return f"<div>{label(widget.description)}{' '.join(marks)}</div>"
    if isinstance(widget, widgets.SelectMultiple):
        marks = [
            f"<b>[{html.escape(str(name))}]</b>" if value in widget.value else html.escape(name)
            for name, value in zip(widget._options_labels, widget._options_values, strict=True)
        ]
        return f"<div>{label(widget.description)}{' '.join(marks)}</div>"
    if isinstance(widget, widgets.Button):
        return f"<div><button disabled>{html.escape(widget.description)}</button></div>"
    if isinstance(widget, widgets.Checkbox):
        mark = "&#9745;" if widget.value else "&#9744;"
        return f"<div>{mark} {html.escape(widget.description)}</div>"
    value = getattr(widget, "value", "")
    if isinstance(value, tuple):
        value = " - ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    elif isinstance(value, float):
        value = f"{value:g}"
    return f"<div>{label(getattr(widget, 'description', ''))}{html.escape(str(value))}</div>"


class _StaticCopy:
    """Adds :func:`static_html` to a widget's display output (a viewer without the
    widget's live state shows it instead of the widget's repr)."""

    def _repr_mimebundle_(self, **kwargs: Any) -> dict[str, Any]:
        bundle = super()._repr_mimebundle_(**kwargs)  # type: ignore[misc]
        note = '<div style="color:#666;font-size:smaller">(as shown when the cell ran)</div>'
        return {**(bundle or {}), "text/html": static_html(self) + note}


@functools.cache
def _with_static_copy(cls: type) -> type:
    return type(cls.__name__, (_StaticCopy, cls), {"__module__": cls.__module__})


def _widget(name: str, *args: Any, **kwargs: Any) -> Any:
    """An ipywidgets control of class ``name`` that also displays as static HTML."""
    import ipywidgets as widgets

    return _with_static_copy(getattr(widgets, name))(*args, **kwargs)


def accepted(decision: Any) -> bool:
    """Whether an :func:`accept_checks` choice says "accept".

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck
    >>> accepted(accept_checks([QualityCheck.at_most("rms", 0.05, 0.1, "px")]))
    True
    """
    return decision.children[-1].value == "accept"


def pick_lasers(procedure: Mapping[str, Any], available_nm: Sequence[float]):
    """A tick box per laser of the rig, the procedure's lasers ticked.

    One box a laser, so a click unticks that laser alone (a multiple-choice list would
    drop every other laser on a plain click).

    Parameters
    ----------
    procedure
        The loaded procedure (its ``lasers_nm`` are the default choice).
    available_nm
        The rig's lasers (``rig.description.lasers_nm``).

    Returns
    -------
    ipywidgets.HBox
        Its tick boxes; ``.value`` is the tuple of ticked wavelengths (nm).

    Examples
    --------
    >>> from sassi_bench.procedure import load_procedure
    >>> picker = pick_lasers(load_procedure("spectral_calibration"), [450, 520, 532, 635, 670])
    >>> picker.value
    (450.0, 520.0, 532.0, 635.0, 670.0)
    >>> picker.children[2].value = False  # 532 nm unticked
    >>> picker.value
    (450.0, 520.0, 635.0, 670.0)
    """
    import ipywidgets as widgets

    pinned = procedure.get("lasers_nm")
    chosen = {float(nm) for nm in (available_nm if pinned is None else pinned)}
    boxes = [
        widgets.Checkbox(
            value=float(nm) in chosen,
            description=f"{float(nm):g} nm",
            indent=False,
            layout=widgets.Layout(width="auto"),
        )
        for nm in available_nm
    ]
    return _laser_choice_class()(boxes, wavelengths=[float(nm) for nm in available_nm])


@functools.cache
def _laser_choice_class() -> type:
    import ipywidgets as widgets

    class LaserChoice(_with_static_copy(widgets.HBox)):  # type: ignore[misc]
        """Tick boxes, one a laser; ``.value`` is the tuple of ticked wavelengths (nm)."""

        def __init__(self, boxes: list[Any], wavelengths: list[float]) -> None:
            super().__init__(boxes)
            self._wavelengths = wavelengths

        @property
        def value(self) -> tuple[float, ...]:
            return tuple(
                nm for nm, box in zip(self._wavelengths, self.children, strict=True) if box.value
            )

    return LaserChoice


def pick_exposure(procedure: Mapping[str, Any]):
    """A slider for the auto-exposure target (fraction of full scale), the procedure's value.

    Returns
    -------
    ipywidgets.FloatSlider

    Examples
    --------
    >>> from sassi_bench.procedure import load_procedure
    >>> pick_exposure(load_procedure("spectral_calibration")).value
    0.6
    """
    return _widget(
        "FloatSlider",
        value=float(procedure["exposure"]["target_fraction"]),
        min=0.1,
        max=0.95,
        step=0.05,
        description="Exposure",
        tooltip="brightest pixel of an all-open frame, as a fraction of full scale",
    )


def checks_table(checks: Iterable[Any]) -> str:
    """An HTML table of quality checks (name, value, tolerance, pass/fail).

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck
    >>> "PASS" in checks_table([QualityCheck.at_most("rms", 0.02, 0.1, "px")])
    True
    """
    from sassi_bench._shared.tables import html_table
    from sassi_bench.bundle.quality import format_tolerance, unit_suffix

    rows = []
    for check in checks:
        mark = "PASS" if check.passed else "FAIL"
        colour = "#1a7f37" if check.passed else "#cf222e"
        rows.append(
            [
                html.escape(check.name),
                f"{check.value:.4g}{html.escape(unit_suffix(check.unit))}",
                f"{html.escape(check.comparison)} {format_tolerance(check.tolerance)}",
                f'<td style="color:{colour};font-weight:bold">{mark}</td>',
            ]
        )
    return html_table(["check", "value", "tolerance", ""], rows)


def accept_checks(checks: Sequence[Any]):
    """Show quality checks and a choice to accept or reject the result.

    The default is "accept" when every check passed and "reject" otherwise, so an
    unattended run never publishes a failed calibration.

    Returns
    -------
    ipywidgets.VBox
        The table and the choice; ``.children[-1].value`` is ``"accept"`` or ``"reject"``.

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck
    >>> box = accept_checks([QualityCheck.at_most("rms", 0.5, 0.1, "px")])
    >>> box.children[-1].value
    'reject'
    """
    import ipywidgets as widgets

    passed = all(c.passed for c in checks)
    choice = widgets.ToggleButtons(
        options=["accept", "reject"], value="accept" if passed else "reject", description="Fit"
    )
    return _widget("VBox", [widgets.HTML(checks_table(checks)), choice])


def show_png(png: bytes, width: int | None = None):
    """An image widget for PNG bytes (e.g. a bundle's report figure).

    Examples
    --------
    >>> show_png(b"\\x89PNG").format
    'png'
    """
    kwargs = {} if width is None else {"width": width}
    return _widget("Image", value=png, format="png", **kwargs)


def pick_excluded_region(slm_shape: tuple[int, int]):
    """A rectangle of the SLM to leave out of the fits (off by default).

    Returns
    -------
    ipywidgets.VBox
        A checkbox and row/column range sliders; read it with :func:`excluded_region`.

    Examples
    --------
    >>> excluded_region(pick_excluded_region((400, 640)))
    []
    """
    import ipywidgets as widgets

    h, w = slm_shape
    return _widget(
        "VBox",
        [
            widgets.Checkbox(value=False, description="exclude a region"),
            widgets.IntRangeSlider(value=(0, h // 4), min=0, max=h, description="rows"),
            widgets.IntRangeSlider(value=(0, w // 4), min=0, max=w, description="columns"),
        ],
    )


def excluded_region(picker) -> list[list[int]]:
    """The ``fit.exclude_regions_slm_px`` entries a :func:`pick_excluded_region` holds."""
    enabled, rows, cols = picker.children
    if not enabled.value:
        return []
    return [[int(rows.value[0]), int(cols.value[0]), int(rows.value[1]), int(cols.value[1])]]


CORNER_PATCHES = ("1", "6", "24", "19")


def pick_chart_corners(start, slm_shape: tuple[int, int]):
    """Sliders for the SLM (u, v) centres of ColorChecker patches 1, 6, 24 and 19.

    Parameters
    ----------
    start
        (4, 2) starting centres (e.g. the detector's,
        :func:`sassi_bench.validate.chart.starting_corners`).
    slm_shape
        (height, width) of the SLM.

    Returns
    -------
    ipywidgets.GridBox
        Read it with :func:`chart_corners`.

    Examples
    --------
    >>> box = pick_chart_corners([[10, 20], [60, 20], [60, 50], [10, 50]], (400, 640))
    >>> chart_corners(box).tolist()
    [[10.0, 20.0], [60.0, 20.0], [60.0, 50.0], [10.0, 50.0]]
    """
    import ipywidgets as widgets

    h, w = slm_shape
    sliders = []
    for name, (u, v) in zip(CORNER_PATCHES, start, strict=True):
        sliders.append(
            widgets.FloatSlider(value=float(u), min=0, max=w - 1, step=0.5, description=f"u {name}")
        )
        sliders.append(
            widgets.FloatSlider(value=float(v), min=0, max=h - 1, step=0.5, description=f"v {name}")
        )
    layout = widgets.Layout(grid_template_columns="repeat(2, 1fr)")
    return _widget("GridBox", sliders, layout=layout)


def chart_corners(picker):
    """The (4, 2) patch centres a :func:`pick_chart_corners` holds."""
    import numpy as np

    return np.array([s.value for s in picker.children], dtype=np.float64).reshape(4, 2)
