"""Lossless compression of raw camera frames: what is possible, and at what CPU cost.

For a few frames of each session under ``<data>/sessions/`` (a calibration run's raw
frames, e.g. a ``bench_chain.py --data DIR`` run), prints:

* the bytes the session's own codec stored, as a share of the raw 16-bit bytes;
* three entropies (bits per pixel, and as a share of 16 bits): of the pixel values
  (order 0), of the residuals of the LOCO-I median predictor (what a good image coder
  can reach), and the **noise floor**: the mean entropy of each pixel's own shot and
  read noise (a Gaussian of the variance the camera's noise model gives the pixel's
  value; its gain, offset and read noise come from the session's rig description). No
  lossless coder can go below the noise floor: it would have to know the noise-free
  frame;
* for each candidate codec usable through zarr v3 (Blosc's zstd and lz4 with byte or
  bit shuffle, zstd levels; pcodec, JPEG-LS and JPEG-XL when ``pcodec`` and
  ``imagecodecs`` are installed): the share of raw bytes kept and the encode and decode
  CPU time of one frame, one thread.

Run: ``python benchmarks/bench_codecs.py DATA [--frames 3] [--session NAME ...]``
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numcodecs
import numpy as np
from numcodecs import Blosc

from sassi_bench.acquire.session import Session


def _entropy(values: np.ndarray) -> float:
    """Order-0 entropy, bits per value."""
    _, counts = np.unique(values, return_counts=True)
    p = counts / counts.sum()
    return float(-(p * np.log2(p)).sum())


def _med_residuals(frame: np.ndarray) -> np.ndarray:
    """Residuals of LOCO-I's median edge detector (JPEG-LS's predictor)."""
    a = frame.astype(np.int32)
    west, north, north_west = a[1:, :-1], a[:-1, 1:], a[:-1, :-1]
    high, low = np.maximum(west, north), np.minimum(west, north)
    guess = np.where(
        north_west >= high, low, np.where(north_west <= low, high, west + north - north_west)
    )
    return a[1:, 1:] - guess


def _noise_floor(frame: np.ndarray, camera: dict) -> float:
    """Mean entropy (bits/px) of each pixel's Gaussian shot + read noise, in ADU."""
    offset = float(camera.get("dark_offset_adu", 100.0))
    gain = float(camera["full_well_e"]) / (2 ** int(camera["bit_depth"]) - 1 - offset)
    electrons = np.clip(frame.astype(np.float64) - offset, 0.0, None) * gain
    sigma = np.sqrt((electrons + float(camera["read_noise_e"]) ** 2) / gain**2 + 1.0 / 12.0)
    return float(np.mean(np.log2(sigma * np.sqrt(2.0 * np.pi * np.e))))


def _codecs() -> dict[str, tuple[Callable, Callable]]:
    """name -> (encode, decode) of each candidate available here."""
    out: dict[str, tuple[Callable, Callable]] = {}
    for cname, level, shuffle in [
        ("zstd", 1, Blosc.SHUFFLE),
        ("zstd", 3, Blosc.SHUFFLE),
        ("zstd", 3, Blosc.BITSHUFFLE),
        ("zstd", 6, Blosc.SHUFFLE),
        ("lz4", 5, Blosc.BITSHUFFLE),
    ]:
        codec = Blosc(cname=cname, clevel=level, shuffle=shuffle)
        kind = "bit" if shuffle == Blosc.BITSHUFFLE else "byte"
        out[f"blosc {cname}-{level} {kind}"] = (codec.encode, codec.decode)
    try:
        from pcodec import ChunkConfig, standalone

        config = ChunkConfig(compression_level=8)
        out["pcodec 8"] = (
            lambda f: standalone.simple_compress(f.ravel(), config),
            standalone.simple_decompress,
        )
    except ImportError:
        pass
    try:
        import imagecodecs

        if imagecodecs.JPEGLS.available:
            out["JPEG-LS"] = (imagecodecs.jpegls_encode, imagecodecs.jpegls_decode)
        if imagecodecs.JPEGXL.available:
            out["JPEG-XL effort 1"] = (
                lambda f: imagecodecs.jpegxl_encode(f, lossless=True, effort=1, numthreads=1),
                lambda b: imagecodecs.jpegxl_decode(b, numthreads=1),
            )
            out["JPEG-XL effort 2"] = (
                lambda f: imagecodecs.jpegxl_encode(f, lossless=True, effort=2, numthreads=1),
                lambda b: imagecodecs.jpegxl_decode(b, numthreads=1),
            )
    except ImportError:
        pass
    return out


def _same(decoded: object, frame: np.ndarray) -> bool:
    """Whether a codec's output is the frame's pixels (bytes or an array)."""
    if isinstance(decoded, bytes | bytearray | memoryview):
        pixels = np.frombuffer(decoded, frame.dtype)
    else:
        pixels = np.asarray(decoded).reshape(-1)
    return pixels.size == frame.size and np.array_equal(pixels, frame.reshape(-1))


def _cpu(action: Callable[[], object]) -> tuple[object, float]:
    start = time.thread_time()
    result = action()
    return result, time.thread_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", type=Path, help="data root holding sessions/")
    parser.add_argument("--frames", type=int, default=3, help="frames sampled per session")
    parser.add_argument("--session", action="append", help="session id(s) (default: all)")
    args = parser.parse_args()
    numcodecs.blosc.set_nthreads(1)
    codecs = _codecs()
    totals: dict[str, list[float]] = {name: [0.0, 0.0, 0.0] for name in codecs}
    raw_total = stored_total = floor_total = 0.0
    ids = args.session or sorted(p.name for p in (args.data / "sessions").iterdir())
    for session_id in ids:
        session = Session.open(session_id, data=args.data)
        steps = sorted(i for i in session.completed if session.plan.steps[i].camera == "spectral")
        if not steps:
            continue
        camera = session.rig["spectral_camera"]
        picks = [
            steps[round(k * (len(steps) - 1) / max(args.frames - 1, 1))] for k in range(args.frames)
        ]
        print(f"\n== {session_id}: {len(steps)} spectral frames, {len(set(picks))} sampled ==")
        for step in dict.fromkeys(picks):
            frame = np.ascontiguousarray(session.read_frame(step))
            raw = frame.nbytes
            slot = session.event(step)["slot"]
            stored = (
                (session.path / "frames.zarr" / "spectral" / "c" / str(slot) / "0" / "0")
                .stat()
                .st_size
            )
            h0, hm = _entropy(frame), _entropy(_med_residuals(frame))
            floor = _noise_floor(frame, camera)
            print(
                f"step {step}: stored {stored / raw:.3f} of raw; bits/px: values {h0:.2f}, "
                f"MED residuals {hm:.2f}, noise floor {floor:.2f} ({floor / 16:.3f} of raw)"
            )
            raw_total += raw * len(steps) / len(set(picks))
            stored_total += stored * len(steps) / len(set(picks))
            floor_total += raw * floor / 16 * len(steps) / len(set(picks))
            for name, (encode, decode) in codecs.items():
                encoded, t_enc = _cpu(lambda: encode(frame))  # noqa: B023
                decoded, t_dec = _cpu(lambda: decode(encoded))  # noqa: B023
                same = _same(decoded, frame)
                ratio = len(encoded) / raw
                totals[name][0] += ratio * raw * len(steps) / len(set(picks))
                totals[name][1] += t_enc
                totals[name][2] += t_dec
                print(
                    f"   {name:20s} {ratio:.3f} of raw  encode {t_enc * 1e3:6.1f} ms  "
                    f"decode {t_dec * 1e3:6.1f} ms{'' if same else '  (NOT LOSSLESS)'}"
                )
    print(
        f"\nall sessions (extrapolated from the samples): raw {raw_total / 1e9:.2f} GB, stored "
        f"{stored_total / 1e9:.2f} GB, noise floor {floor_total / 1e9:.2f} GB"
    )
    for name, (size, _, _) in totals.items():
        print(f"   {name:20s} {size / 1e9:.2f} GB")


if __name__ == "__main__":
    main()
