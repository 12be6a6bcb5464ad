"""The calibration report's figure of a design rig: difference maps, the shift against
wavelength, the candidates' fits and the verdict as its title."""

from __future__ import annotations

import numpy as np

from sassi_bench.plots.design_comparison import design_comparison_figure
from sassi_bench.plots.png import figure_png
from sassi_bench.reduce.design_comparison import (
    Candidate,
    DesignComparison,
    Diagnosis,
    FieldMaps,
)


def _maps(dy: float = 0.0, widen: float = 0.0) -> FieldMaps:
    u, v = (a.ravel() for a in np.meshgrid(np.linspace(0, 319, 7), np.linspace(0, 199, 5)))
    lam = np.linspace(450.0, 670.0, 5)
    x = 100 + 0.9 * u[:, None] + 0.5 * (lam - 450.0)
    y = 50 + 0.9 * v[:, None] + dy + 0 * lam
    c = (1.0 + widen) ** 2 * np.ones_like(x)
    return FieldMaps(u, v, lam, x, y, c, 0.5 * c, 0.1 * c)


def _shift(amount: float) -> dict:
    return {"image": {"decenter_mm": [0.0, amount]}}


def test_a_bench_off_its_design_is_drawn_with_its_diagnosis_in_red():
    named = Candidate("camera lens (surfaces 8-10) decentred in y", "mm", 0.02, _shift, 1e3, "um")
    other = Candidate("camera off focus", "mm", 0.02, _shift, 1e3, "um")
    found = DesignComparison(
        _maps(), _maps(dy=-9.0), (Diagnosis(named, 0.05, 0.99), Diagnosis(other, 0.1, 0.02))
    )
    fig = design_comparison_figure(found)
    assert "decentred in y by +50 um" in " ".join(fig._suptitle.get_text().split())
    assert fig._suptitle.get_color() == "tab:red"
    bars = next(ax for ax in fig.axes if ax.get_title().startswith("Each candidate"))
    labels = [t.get_text() for t in bars.get_yticklabels()]
    assert labels[-1] == "camera lens (surfaces 8-10) decentred in y by +50 um"  # on top
    assert figure_png(fig)[:4] == b"\x89PNG"


def test_a_bench_that_matches_its_design_says_so():
    found = DesignComparison(_maps(), _maps(dy=0.02, widen=0.01), ())
    fig = design_comparison_figure(found)
    assert fig._suptitle.get_text().splitlines()[1].startswith("The bench matches its design")
    assert fig._suptitle.get_color() == "tab:green"
    # the position map starts at zero, so a match does not look like a large shift
    position = next(ax for ax in fig.axes if ax.get_title().startswith("position: measured"))
    assert position.collections[0].get_clim()[0] == 0.0
