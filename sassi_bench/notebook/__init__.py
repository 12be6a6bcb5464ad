"""Notebook helpers: the widgets where a person decides, each with a default that a
notebook run without a person (CI, ``jupyter nbconvert --execute``) keeps."""

from sassi_bench.notebook.bundles import bundle_for
from sassi_bench.notebook.display import say_clipping, show
from sassi_bench.notebook.live import LiveView, live_view
from sassi_bench.notebook.outputs import new_report_folder, save_cube
from sassi_bench.notebook.publishing import (
    latest_summary,
    publish_guide_once,
    publish_once,
    publish_spectral_once,
)
from sassi_bench.notebook.widgets import (
    accept_checks,
    accepted,
    chart_corners,
    checks_table,
    excluded_region,
    pick_chart_corners,
    pick_excluded_region,
    pick_exposure,
    pick_lasers,
    show_png,
    static_html,
)

__all__ = [
    "LiveView",
    "accept_checks",
    "accepted",
    "bundle_for",
    "chart_corners",
    "checks_table",
    "excluded_region",
    "latest_summary",
    "live_view",
    "new_report_folder",
    "pick_chart_corners",
    "pick_excluded_region",
    "pick_exposure",
    "pick_lasers",
    "publish_guide_once",
    "publish_once",
    "publish_spectral_once",
    "save_cube",
    "say_clipping",
    "show",
    "show_png",
    "static_html",
]
