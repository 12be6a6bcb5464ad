"""A napari plugin for the workbench's cubes and snapshot videos (``pip install
"sassi-bench[napari]"``): open a NetCDF or ENVI cube or a ``video.zarr`` with File > Open
(or ``napari cube.nc``), and dock *Plugins > SASSI bench > Spectrum* for the spectrum of the
clicked pixel, or the mean spectrum and spread of each region drawn on a Shapes or Labels
layer, in nanometres, and the bundle the cube came from.

The readers (:mod:`sassi_bench.napari.reader`) return napari's layer data tuples and do not
import napari; the dock (:mod:`sassi_bench.napari.widget`) needs napari and Qt.
"""
