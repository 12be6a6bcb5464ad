"""Make ``napari_spectrum_dock.png``: the napari plugin's spectrum dock showing the mean
spectra (and standard deviation bands) of regions drawn over a cube the workbench wrote.

The viewer is napari's headless ``ViewerModel`` and the dock is grabbed from an offscreen
Qt, so no display is needed. Run with the napari extra installed::

    python docs/images/napari_spectrum_dock.py CUBE.nc --region 60 90 100 130 \\
        --region 60 330 100 370 --out docs/images/napari_spectrum_dock.png

Each ``--region ROW0 COL0 ROW1 COL1`` is a rectangle drawn on a Shapes layer (cube pixels).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cube", type=Path, help="a NetCDF or ENVI cube the workbench wrote")
    parser.add_argument(
        "--region", nargs=4, type=float, action="append", required=True,
        metavar=("ROW0", "COL0", "ROW1", "COL1"), help="a rectangle to draw (repeatable)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path(__file__).with_suffix(".png"))
    parser.add_argument("--size", nargs=2, type=int, default=(620, 520), metavar=("W", "H"))
    args = parser.parse_args()

    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from napari.components import ViewerModel
    from napari.plugins import _initialize_plugins
    from qtpy.QtWidgets import QApplication

    from sassi_bench.napari.widget import spectrum_widget

    app = QApplication.instance() or QApplication([])
    _initialize_plugins()
    viewer = ViewerModel()
    viewer.open(str(args.cube), plugin="sassi-bench")
    dock = spectrum_widget(viewer)
    rectangles = [[[r0, c0], [r1, c1]] for r0, c0, r1, c1 in args.region]
    viewer.add_shapes(rectangles, shape_type="rectangle", name="drawn regions")
    dock.resize(*args.size)
    dock.show()
    app.processEvents()
    dock.canvas.draw()
    app.processEvents()
    if not dock.grab().save(str(args.out)):
        raise SystemExit(f"could not write {args.out}")
    print(f"wrote {args.out} ({len(dock.shown_regions)} regions)")
    dock.close()


if __name__ == "__main__":
    main()
