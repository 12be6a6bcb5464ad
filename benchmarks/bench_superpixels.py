"""Superpixels at the SASSI paper's SLM crop: speed and accuracy of the methods compared in
:mod:`sassi_bench.snapshot.superpixels`.

A 698 x 931 guide image of 400 known regions (a Voronoi partition of random points,
random colours, 2 % noise) is segmented into ``--segments`` superpixels (967: the lattice
of the mask rule at an 8-row pitch) by each method; then the scene is moved (2 px down
and right, 0.25 degrees) and segmented again, where a video method starts from the
previous frame's centres. For each: CPU ms per frame (of the calling thread, and of the
whole process: OpenCV spreads some of its work over its own threads), boundary recall
(share of the true boundary pixels within 2 px of a superpixel boundary) and Neubert and
Protzel's corrected undersegmentation error, medians of ``--rounds`` runs. Last, a long pan
(2 and 3 px and 0.25 degrees a frame, ``--pan`` frames): the video method against a fresh
grid every frame, every 10 frames (does starting from the last centres drift?).

Run: ``python benchmarks/bench_superpixels.py [--rounds 5] [--segments 967]``
"""

from __future__ import annotations

import argparse
import statistics
import time

import cv2
import numpy as np
from scipy import ndimage

from sassi_bench.snapshot.superpixels import superpixels

SHAPE = (698, 931)


def scene(rng: np.random.Generator, regions: int = 400, shift=(0.0, 0.0), angle=0.0):
    """The known regions (labels) and their image: RGB float32, colours plus 2 % noise."""
    h, w = SHAPE
    points = rng.uniform((0, 0), (h, w), (regions, 2))
    colours = rng.uniform(0.05, 1.0, (regions, 3))
    yy, xx = np.mgrid[:h, :w].astype(np.float64)
    t = np.deg2rad(angle)
    cy, cx = h / 2, w / 2
    # The scene moved by ``shift`` and turned by ``angle``: sample it at the points the
    # motion brought here.
    y = cy + (yy - cy - shift[0]) * np.cos(t) + (xx - cx - shift[1]) * np.sin(t)
    x = cx - (yy - cy - shift[0]) * np.sin(t) + (xx - cx - shift[1]) * np.cos(t)
    labels = nearest_point(points, y, x)
    noise = rng.normal(0.0, 0.02, (h, w, 3))
    return labels, (colours[labels] + noise).astype(np.float32)


def nearest_point(points, y, x):
    from scipy.spatial import cKDTree

    _, index = cKDTree(points).query(np.stack([y.ravel(), x.ravel()], axis=1))
    return index.reshape(y.shape).astype(np.int32)


def boundaries(labels: np.ndarray) -> np.ndarray:
    edge = np.zeros(labels.shape, bool)
    edge[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edge[1:, :] |= labels[1:, :] != labels[:-1, :]
    return edge


def boundary_recall(truth: np.ndarray, segments: np.ndarray, tolerance: int = 2) -> float:
    near = ndimage.binary_dilation(
        boundaries(segments), structure=np.ones((3, 3), bool), iterations=tolerance
    )
    true_edges = boundaries(truth)
    return float((near & true_edges).sum() / true_edges.sum())


def undersegmentation(truth: np.ndarray, segments: np.ndarray) -> float:
    """Neubert and Protzel: sum over true regions G and superpixels S meeting G of
    min(|S in G|, |S out of G|), over the pixel count."""
    pairs = truth.astype(np.int64) * (segments.max() + 1) + segments
    table = np.bincount(pairs.ravel())
    inside = table[table > 0]
    seg_of = np.flatnonzero(table) % (segments.max() + 1)
    size = np.bincount(segments.ravel())
    return float(np.minimum(inside, size[seg_of] - inside).sum() / truth.size)


def opencv_slic(image, segments, shrink=2, iterations=2):
    """The former method: OpenCV's ximgproc SLIC on the CIELAB features shrunk by 2."""
    from sassi_bench.snapshot.superpixels import guide_features

    features = guide_features(image)
    h, w = features.shape[:2]
    region = max(2, round(float(np.sqrt(h * w / segments))))
    small = cv2.resize(features, (w // shrink, h // shrink), interpolation=cv2.INTER_AREA)
    slic = cv2.ximgproc.createSuperpixelSLIC(
        small, algorithm=cv2.ximgproc.SLIC, region_size=max(2, round(region / shrink)), ruler=10.0
    )
    slic.iterate(iterations)
    slic.enforceLabelConnectivity(max(1, 25 // (shrink * shrink)))
    return cv2.resize(slic.getLabels(), (w, h), interpolation=cv2.INTER_NEAREST)


def timed(fn, *args, **kwargs):
    start, cpu = time.thread_time(), time.process_time()
    out = fn(*args, **kwargs)
    return out, 1e3 * (time.thread_time() - start), 1e3 * (time.process_time() - cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--segments", type=int, default=967)
    parser.add_argument("--pan", type=int, default=40)
    args = parser.parse_args()
    n = args.segments
    methods = {
        "OpenCV SLIC at half size, 2 iter.": lambda im, prev: (opencv_slic(im, n), None),
        "ours at half size, 2 iter.": lambda im, prev: _ours(im, n, 2, None),
        "ours at half size, 1 iter.": lambda im, prev: _ours(im, n, 1, None),
        "ours at half size, 1 iter. from last centres": lambda im, prev: _ours(im, n, 1, prev),
        "ours at half size, 2 iter. from last centres": lambda im, prev: _ours(im, n, 2, prev),
        "OpenCV SLIC at full size, 2 iter.": lambda im, prev: (opencv_slic(im, n, 1), None),
        "ours at full size, 2 iter.": lambda im, prev: _ours(im, n, 2, None, shrink=1),
    }
    rows = {name: [] for name in methods}
    for r in range(args.rounds):
        _, image0 = scene(np.random.default_rng(r))
        truth1, image1 = scene(np.random.default_rng(r), shift=(2.0, 2.0), angle=0.25)
        for name, method in methods.items():
            (_, previous), _, _ = timed(method, image0, None)  # the previous frame
            (labels, _), cpu, process = timed(method, image1, previous)
            rows[name].append(
                (cpu, process, boundary_recall(truth1, labels), undersegmentation(truth1, labels))
            )
    print(f"{SHAPE[0]} x {SHAPE[1]}, 400 regions, {n} superpixels asked, medians of {args.rounds}")
    print(f"{'method':46s} {'cpu ms':>7s} {'proc ms':>7s} {'recall':>7s} {'underseg':>8s}")
    for name, values in rows.items():
        med = [statistics.median(v[i] for v in values) for i in range(4)]
        print(f"{name:46s} {med[0]:7.1f} {med[1]:7.1f} {med[2]:7.3f} {med[3]:8.3f}")
    print("\na pan, frame by frame: recall / undersegmentation / superpixels")
    previous = None
    for t in range(args.pan + 1):
        truth, image = scene(np.random.default_rng(0), shift=(2.0 * t, 3.0 * t), angle=0.25 * t)
        video = superpixels(image, n, shrink=2, seeds=previous)
        previous = video.centres
        if t % 10 == 0:
            fresh = superpixels(image, n, shrink=2)
            print(
                f"frame {t:3d}: from last centres {boundary_recall(truth, video.labels):.3f} / "
                f"{undersegmentation(truth, video.labels):.3f} / {video.count}; fresh grid "
                f"{boundary_recall(truth, fresh.labels):.3f} / "
                f"{undersegmentation(truth, fresh.labels):.3f} / {fresh.count}"
            )


def _ours(image, n, iterations, previous, shrink=2):
    segments = superpixels(image, n, iterations=iterations, shrink=shrink, seeds=previous)
    return segments.labels, segments.centres


if __name__ == "__main__":
    main()
