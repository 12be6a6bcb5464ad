"""How long the napari plugin's readers take to open a cube and a snapshot video.

* a NetCDF cube (``--cube``, e.g. notebook 03's ``<data>/cubes/*.nc``) and its ENVI export,
  each against the same file opened and loaded by xarray / Spectral Python alone (the
  baseline, timed in the same run, so the ratio is the plugin's own cost: the sRGB
  rendering, the transposition, the metadata);
* a ``--frames``-frame snapshot video store of the bundle's size (``--bundle``), written
  here with rank-1 frames of ``--regions`` random regions (the reader's cost does not
  depend on their content): the time to open it (the first frame's dense cube, for the
  contrast limits) and the time each further frame takes when shown (its dense cube and
  sRGB rendering), both against one frame read with
  :func:`sassi_bench.snapshot.video_store.read_frame` and made dense.

Run: ``python benchmarks/bench_napari_reader.py --cube CUBE.nc --bundle BUNDLE_DIR
[--frames 10] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sassi_bench.bundle import load
from sassi_bench.napari.reader import read_envi, read_netcdf, read_video
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.video_store import VideoStore, read_frame
from sassi_bench.spectra.cube_io import write_envi


def _best(run: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _video(path: Path, bundle, frames: int, regions: int) -> None:
    h, w = bundle.slm_shape
    store = VideoStore(path, bundle, units="relative photon radiance per bin")
    rng = np.random.default_rng(0)
    for t in range(frames):
        labels = rng.integers(0, regions, (h, w))
        cube = Rank1Cube(
            labels.astype(np.intp),
            rng.uniform(0.5, 1.5, (h, w)).astype(np.float32),
            rng.uniform(0, 1, (regions, bundle.wavelengths.size)).astype(np.float32),
        )
        store.append(cube, np.zeros((h, w), bool), time_s=0.05 * t, frame_index=t)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cube", type=Path, required=True)
    parser.add_argument("--bundle", type=Path, required=True)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--regions", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    import spectral.io.envi as envi
    import xarray as xr

    def plain_netcdf() -> None:
        with xr.open_dataset(args.cube) as ds:
            ds["radiance"].values  # noqa: B018

    with tempfile.TemporaryDirectory() as tmp:
        with xr.open_dataset(args.cube) as ds:
            shape = ds["radiance"].shape
            header = write_envi(ds.load(), Path(tmp) / "cube")
        rows = [
            ("NetCDF cube", _best(lambda: read_netcdf(args.cube), args.repeats),
             _best(plain_netcdf, args.repeats)),
            ("ENVI cube", _best(lambda: read_envi(header), args.repeats),
             _best(lambda: envi.open(str(header)).load(), args.repeats)),
        ]  # fmt: skip
        bundle = load(args.bundle)
        video = Path(tmp) / "video.zarr"
        _video(video, bundle, args.frames, args.regions)

        def plain_frame() -> None:
            read_frame(video, 0)[0].dense()

        def shown_frames() -> None:
            (rgb, _, _), (cube, _, _) = read_video(video)
            for t in range(1, args.frames):
                cube[t], rgb[t]

        opened = _best(lambda: read_video(video), args.repeats)
        per_frame = (_best(shown_frames, args.repeats) - opened) / (args.frames - 1)
        one_frame = _best(plain_frame, args.repeats)
        rows.append((f"{args.frames}-frame video, open", opened, one_frame))
        rows.append(("video, each frame shown", per_frame, one_frame))
    print(f"cube {shape} (y, x, wavelength); video of {bundle.slm_shape} x {args.frames} frames")
    print(f"{'file':24s} {'reader s':>9s} {'baseline s':>11s} {'ratio':>6s}")
    for name, reader, baseline in rows:
        print(f"{name:24s} {reader:9.3f} {baseline:11.3f} {reader / baseline:6.2f}")


if __name__ == "__main__":
    main()
