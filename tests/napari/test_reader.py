"""The napari readers open the workbench's cubes and videos with wavelength as an axis.

They return napari's layer data tuples, so these tests need neither napari nor Qt.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.errors import SassiBenchError
from sassi_bench.napari.reader import get_reader, read_envi, read_netcdf, read_video
from sassi_bench.napari.spectrum import pixel_spectrum, provenance_text
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.video_store import VideoStore
from sassi_bench.spectra.cube_io import spectral_cube_dataset, write_envi, write_netcdf

WAV = np.linspace(420.0, 680.0, 14)
EDGES = np.concatenate([[WAV[0] - 10.0], (WAV[:-1] + WAV[1:]) / 2, [WAV[-1] + 10.0]])
ATTRS = {"bundle_rig": "sim", "bundle_version": "v0002", "session_id": "lab-scan", "scene": "cc"}


def _cube(h: int = 6, w: int = 9) -> np.ndarray:
    """(H, W, B): each pixel a Gaussian peaking at a wavelength that grows along x."""
    peaks = np.linspace(450.0, 650.0, w)[None, :, None]
    return np.broadcast_to(
        np.exp(-(((WAV - peaks) / 40.0) ** 2)) * (1.0 + np.arange(h))[:, None, None], (h, w, 14)
    ).astype(np.float32)


@pytest.fixture
def netcdf(tmp_path: Path) -> Path:
    ds = spectral_cube_dataset(
        _cube(), WAV, EDGES, units="relative photon radiance per bin", attrs=ATTRS
    )
    path = write_netcdf(ds, tmp_path / "scan.nc")
    write_envi(ds, tmp_path / "scan")
    return path


def _check_layers(layers, name: str) -> tuple[np.ndarray, dict]:
    (rgb, rgb_kwargs, rgb_kind), (cube, kwargs, kind) = layers
    assert (rgb_kind, kind) == ("image", "image") and rgb_kwargs["rgb"] is True
    assert kwargs["name"] == name and rgb_kwargs["name"] == f"{name} (sRGB)"
    assert rgb.shape == (6, 9, 3) and rgb.min() >= 0.0 and rgb.max() <= 1.0
    # Wavelength is the first axis; the slider reads nm: translate + scale * index.
    np.testing.assert_allclose(kwargs["metadata"]["wav"], WAV)
    axis = kwargs["translate"][0] + kwargs["scale"][0] * np.arange(WAV.size)
    np.testing.assert_allclose(axis, WAV, atol=1e-9)
    assert kwargs["axis_labels"] == ("wavelength (nm)", "y", "x")
    assert kwargs["metadata"]["type"] == "HSIf"
    return np.asarray(cube), kwargs


def test_a_netcdf_cube_opens_with_its_wavelengths_and_provenance(netcdf: Path):
    cube, kwargs = _check_layers(get_reader(str(netcdf))(str(netcdf)), "scan")
    np.testing.assert_allclose(cube, np.moveaxis(_cube(), -1, 0))
    assert kwargs["metadata"]["provenance"]["bundle_version"] == "v0002"
    assert kwargs["metadata"]["units"] == "relative photon radiance per bin"
    assert provenance_text(kwargs["metadata"]).startswith("bundle: sim/v0002\nsession_id: lab-")


def test_an_envi_cube_opens_the_same_and_finds_its_netcdf_twin(netcdf: Path):
    header = netcdf.with_suffix(".hdr")
    assert get_reader(str(header)) is not None and get_reader(str(header.with_suffix(".img")))
    cube, kwargs = _check_layers(read_envi(header), "scan")
    np.testing.assert_allclose(cube, np.moveaxis(_cube(), -1, 0))
    assert kwargs["metadata"]["provenance"]["session_id"] == "lab-scan"


def test_the_clicked_pixels_spectrum_is_the_cubes(netcdf: Path):
    _, (cube, kwargs, _) = read_netcdf(netcdf)
    wav, values = pixel_spectrum(cube, kwargs["metadata"], (500.0, 2.4, 7.6))
    np.testing.assert_allclose(wav, WAV)
    np.testing.assert_allclose(values, _cube()[2, 8])
    assert WAV[np.argmax(values)] == pytest.approx(625.0, abs=20.0)  # the peak of column 8
    outside = pixel_spectrum(cube, kwargs["metadata"], (500.0, 6.0, 0.0))
    assert outside[0].size == 0


def test_files_it_does_not_read_are_left_to_others(tmp_path: Path):
    assert get_reader(str(tmp_path / "photo.png")) is None
    assert get_reader(str(tmp_path)) is None
    (tmp_path / "other.nc").write_bytes(b"not a cube")
    with pytest.raises((SassiBenchError, OSError, ValueError)):
        read_netcdf(tmp_path / "other.nc")


def _video(path: Path, frames: int, h: int = 5, w: int = 7) -> list[np.ndarray]:
    bundle = SimpleNamespace(
        slm_shape=(h, w), wavelengths=WAV, bin_edges=EDGES, rig_name="sim", version="v0003"
    )
    store = VideoStore(path, bundle, units="relative photon radiance per bin")
    dense = []
    rng = np.random.default_rng(0)
    for t in range(frames):
        labels = (np.arange(h * w).reshape(h, w) // 6) % 4
        cube = Rank1Cube(
            labels.astype(np.intp),
            rng.uniform(0.5, 1.5, (h, w)).astype(np.float32),
            rng.uniform(0.0, 1.0, (4, WAV.size)).astype(np.float32),
        )
        store.append(cube, np.zeros((h, w), bool), time_s=0.05 * t, frame_index=t)
        dense.append(np.moveaxis(cube.dense(), -1, 0))
    return dense


def test_a_video_opens_with_time_then_wavelength(tmp_path: Path):
    path = tmp_path / "video.zarr"
    dense = _video(path, frames=3)
    reader = get_reader(str(path))
    assert reader is not None
    (rgb, _, _), (cube, kwargs, _) = reader(str(path))
    assert cube.shape == (3, WAV.size, 5, 7) and rgb.shape == (3, 5, 7, 3)
    np.testing.assert_allclose(cube[1], dense[1])
    np.testing.assert_allclose(cube[2, 3:5, 1], dense[2][3:5, 1])
    np.testing.assert_allclose(np.asarray(cube), np.stack(dense))
    assert kwargs["axis_labels"] == ("time", "wavelength (nm)", "y", "x")
    assert kwargs["metadata"]["provenance"]["frames"] == 3
    assert kwargs["metadata"]["provenance"]["bundle_version"] == "v0003"
    _, values = pixel_spectrum(cube, kwargs["metadata"], (2.0, 500.0, 4.0, 6.0))
    np.testing.assert_allclose(values, dense[2][:, 4, 6], rtol=1e-6)


def test_a_folder_that_is_no_video_is_refused_clearly(tmp_path: Path):
    import zarr

    zarr.open_group(str(tmp_path / "empty.zarr"), mode="w")
    with pytest.raises(SassiBenchError, match="not a snapshot video store"):
        read_video(tmp_path / "empty.zarr")
