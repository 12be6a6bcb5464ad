"""NetCDF cubes: CF units on every variable, the response and bin edges they carry, and
files written before (words in ``units``, no bounds) still read by the loaders."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from sassi_bench.errors import SassiBenchError
from sassi_bench.spectra.cube_io import spectral_cube_dataset, units_label, write_netcdf
from sassi_bench.validate.snapshot import load_scan_cube

#: Units a CF reader (UDUNITS) understands, as these cubes use them.
UDUNITS = {"1", "nm", "s", "count", "count s-1"}


@pytest.fixture()
def bins():
    edges = np.linspace(400.0, 700.0, 7)
    return (edges[:-1] + edges[1:]) / 2, edges


def test_every_variable_has_cf_units_and_the_cube_carries_its_response(bins, tmp_path):
    centres, edges = bins
    rng = np.random.default_rng(1)
    raw = rng.random((3, 4, 6)).astype(np.float32)  # camera ADU per second per bin
    response = np.linspace(2.0, 5.0, 6)
    ds = spectral_cube_dataset(
        (raw / response).astype(np.float32), centres, edges,
        units="relative photon radiance per bin", response=response, exposure_s=0.25,
        origin=(10, 20),
    )  # fmt: skip
    path = write_netcdf(ds, tmp_path / "cube.nc")
    with xr.open_dataset(path) as back:
        assert back.attrs["Conventions"] == "CF-1.10"
        for name in [*back.data_vars, *back.coords]:
            assert back[name].attrs.get("long_name"), name
            if name == "wavelength_bnds":  # CF bounds take the units of their coordinate
                continue
            assert back[name].attrs.get("units") in UDUNITS, name
            if name in back.coords and back[name].dtype.kind == "f":
                assert "_FillValue" not in back[name].encoding, name
        assert back["radiance"].attrs["units"] == "1"
        assert units_label(back["radiance"]) == "relative photon radiance per bin"
        # Without the bundle: radiance * response is the camera's ADU per second per bin.
        assert back["response"].attrs["units"] == "count s-1"
        np.testing.assert_allclose(back["radiance"] * back["response"], raw, rtol=1e-6)
        assert float(back["exposure_time"]) == 0.25 and back["exposure_time"].attrs["units"] == "s"
        # The bin edges, as CF bounds and as the lower/upper coordinates of older files.
        assert back["wavelength"].attrs["bounds"] == "wavelength_bnds"
        assert back["wavelength"].attrs["standard_name"] == "radiation_wavelength"
        np.testing.assert_array_equal(back["wavelength_bnds"][:, 0], edges[:-1])
        np.testing.assert_array_equal(back["wavelength_bnds"][:, 1], edges[1:])
        np.testing.assert_array_equal(back["wavelength_upper"], edges[1:])
        assert int(back.y[0]) == 10 and int(back.x[0]) == 20


def test_a_camera_units_cube_has_no_response_and_units_are_checked(bins):
    centres, edges = bins
    cube = np.zeros((2, 2, 6), np.float32)
    ds = spectral_cube_dataset(cube, centres, edges, units="camera ADU per second per bin")
    assert ds["radiance"].attrs["units"] == "count s-1" and "response" not in ds
    with pytest.raises(SassiBenchError, match="no UDUNITS form"):
        spectral_cube_dataset(cube, centres, edges, units="furlongs per bin")
    with pytest.raises(SassiBenchError, match="a response of shape"):
        spectral_cube_dataset(
            cube, centres, edges, units="camera ADU per second per bin", response=np.ones(6)
        )


def test_scan_cubes_written_before_still_load(bins, tmp_path):
    """A file as the cubes were written before (words in ``units``, no bounds, response
    or Conventions) and a new one both load, with the same units in words."""
    centres, edges = bins
    cube = np.random.default_rng(2).random((3, 4, 6)).astype(np.float32)
    old = xr.Dataset(
        {
            "radiance": (("y", "x", "wavelength"), cube,
                         {"units": "relative photon radiance per bin"}),
            "quality": (("y", "x"), np.zeros((3, 4), np.uint8), {"description": "0 = good"}),
        },
        coords={
            "y": ("y", np.arange(3), {"units": "pixel"}),
            "x": ("x", np.arange(4), {"units": "pixel"}),
            "wavelength": ("wavelength", centres, {"units": "nm"}),
            "wavelength_lower": ("wavelength", edges[:-1], {"units": "nm"}),
            "wavelength_upper": ("wavelength", edges[1:], {"units": "nm"}),
        },
    )  # fmt: skip
    old.to_netcdf(tmp_path / "old.nc")
    new = spectral_cube_dataset(
        cube, centres, edges, units="relative photon radiance per bin", response=np.ones(6)
    )
    write_netcdf(new, tmp_path / "new.nc")
    bundle = SimpleNamespace(slm_shape=(3, 4), wavelengths=centres)
    for name in ("old.nc", "new.nc"):
        reference = load_scan_cube(tmp_path / name, bundle)
        np.testing.assert_array_equal(reference.cube, cube)
        assert reference.units == "relative photon radiance per bin"
        assert reference.valid.all()
