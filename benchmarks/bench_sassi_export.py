"""Size, time and peak memory of the ``sassi-mat`` export at the prototype's scale.

Each case runs in a fresh process (so that its peak resident memory is its own) and
writes ``calibstack.mat`` and ``reverse_lookup.mat`` into a temporary folder, which is
deleted afterwards:

- ``exact``: positions stored exactly at zlib level 1 (what the export wrote before it
  rounded positions: the baseline of the ratios printed);
- ``1/64 px``: the default, positions rounded to 1/64 px, zlib level 6;
- ``paper``: the default at ``--wavelengths paper`` (every 10 nm);
- ``load``: ``scipy.io.loadmat`` of the default files, both held as the authors'
  ``__main__`` holds them (its peak memory is what a lab's machine needs before the
  ``- 1`` copies ``__main__`` makes of the tables, which double it).

Without ``--bundle`` the bundle is synthetic (the helpers of ``tests/bundle/conftest.py``
with the prototype's 1920 x 1080 SLM on a 2048 x 2048 camera, 68 bins): it is built in
seconds, and the export's cost depends only on those shapes, not on how the bundle was
calibrated. ``--bundle DIR`` measures a real one instead (for instance a calibrated
``sim-prototype`` bundle). The exact export of the prototype writes about 1.8 GB.

Run: ``python benchmarks/bench_sassi_export.py [--bundle DIR] [--cases exact,1/64,paper,load]``

``--rig sim-prototype [--data DIR]`` instead runs the SASSI authors' published code on the
exports of a virtual bench, as ``tests/export/test_sassi_upstream.py`` does on ``sim``:
it calibrates the rig spectrally (or reuses the bundle of an earlier run in ``DIR``) with
the bench's true guide homography added, takes an adaptive snapshot of the natural
scene, writes ``bundle export --format sassi-mat`` and ``snapshot export --format
sassi-mat`` (each in its own process: time, peak memory, size; the capture export
includes choosing ``vsize`` by their extraction), runs the README's calls of their code
(``tests/export/sassi_upstream_run.py``) with the exported window and with their former
3 rows, and prints their spectra at the open pixels and their rank-1 against the
bench's truth (one gain, 8 px border) beside this package's. About 40 minutes and 12 GB
on two cores the first time (most of it the calibration).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_CASES = {
    "exact": {"position_quantum_px": 0.0},
    "1/64": {},
    "paper": {"wavelengths": "paper"},
}


def synthetic_prototype(data: Path) -> Path:
    """Publish a prototype-sized synthetic bundle under ``data``; returns its folder."""
    helpers = Path(__file__).parents[1] / "tests" / "bundle" / "conftest.py"
    spec = importlib.util.spec_from_file_location("synthetic_bundle_helpers", helpers)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # the helpers look themselves up there
    spec.loader.exec_module(module)
    module.SLM_SHAPE = (1080, 1920)
    rig = dict(
        module.RIG,
        name="proto",
        slm={"shape": [1080, 1920], "contrast_eps": 0.002},
        spectral_camera={"width": 2048, "height": 2048},
    )
    return module.publish_synthetic(data, rig=rig)


def _child(bundle_dir: str, case: str, out: str) -> None:
    """One case in this process; prints a JSON line."""
    start = time.perf_counter()
    cpu = time.process_time()
    if case == "load":
        from scipy.io import loadmat

        # __main__ holds both files' variables at once (then copies the tables).
        held = [loadmat(Path(out) / name) for name in ("calibstack.mat", "reverse_lookup.mat")]
        sizes = {}
        del held
    else:
        from sassi_bench.bundle import load
        from sassi_bench.export.sassi_mat import export_sassi_mat

        done = export_sassi_mat(load(bundle_dir), out, progress=False, **_CASES[case])
        sizes = {k: v for k, v in done.sizes.items() if k.endswith(".mat")}
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    result = {
        "wall_s": time.perf_counter() - start,
        "cpu_s": time.process_time() - cpu,
        "peak_bytes": peak,
        "sizes": sizes,
    }
    print(json.dumps(result))


def _run(bundle_dir: Path, case: str, out: Path) -> dict:
    command = [sys.executable, __file__, "--child", case, str(bundle_dir), str(out)]
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _psnr_one_gain(estimate, reference) -> float:
    import numpy as np

    est = np.asarray(estimate, np.float64)
    ref = np.asarray(reference, np.float64)
    gain = (est * ref).sum() / (ref * ref).sum()
    return float(10 * np.log10((gain * ref).max() ** 2 / np.mean((est - gain * ref) ** 2)))


def _child_capture(bundle_dir: str, session: str, data: str, out: str) -> None:
    """``snapshot export`` of one frame in this process; prints a JSON line."""
    start = time.perf_counter()
    cpu = time.process_time()
    from sassi_bench.workflows.snapshot_ids import open_snapshots

    from sassi_bench.acquire.snapshots import GUIDE_STEP, SPECTRAL_STEP
    from sassi_bench.bundle import load
    from sassi_bench.export.adaptive_cassi import export_adaptive_cassi

    video = open_snapshots(session, data=data)
    done = export_adaptive_cassi(
        load(bundle_dir), video.frames[0], SPECTRAL_STEP, out, guide_steps=[GUIDE_STEP]
    )
    choice = done.vsize_choice
    print(
        json.dumps({
            "wall_s": time.perf_counter() - start,
            "cpu_s": time.process_time() - cpu,
            "peak_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
            "sizes": {done.path.name: done.path.stat().st_size},
            "vsize": done.vsize,
            "scores": dict(zip(choice.candidates.tolist(), choice.scores_db.tolist(), strict=True)),
        })
    )  # fmt: skip


def _run_child(command: list[str]) -> dict:
    done = subprocess.run(command, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _measured(name: str, result: dict) -> str:
    total = sum(result["sizes"].values())
    return (
        f"{name}: wall {result['wall_s']:.1f} s, cpu {result['cpu_s']:.1f} s, peak "
        f"{result['peak_bytes'] / 1e9:.2f} GB, {total / 1e6:.1f} MB"
    )


def rig_accuracy(rig_name: str, data: Path) -> None:
    """Their code and ours on one snapshot of ``rig_name``, and the exports' costs."""
    import dataclasses

    import numpy as np
    from sassi_bench.workflows.procedure import load_procedure

    from sassi_bench import open_rig
    from sassi_bench.bundle import load, publish
    from sassi_bench.bundle.errors import BundleError
    from sassi_bench.rig.sim import truth
    from sassi_bench.workflows.snapshot import reconstruct_snapshots, take_snapshots
    from sassi_bench.workflows.spectral import run_spectral_calibration

    rig = open_rig(rig_name)
    guided = data / "guided"
    try:
        bundle = load(rig=rig_name, data=guided)
    except BundleError:  # calibrate once; later runs with the same --data reuse it
        result = run_spectral_calibration(
            rig, load_procedure("spectral_calibration"), data=data / "spectral",
            session_id="bench", progress=True, figures=False, allow_failed=True,
        )  # fmt: skip
        spectral = load(result.bundle_path)
        models = dataclasses.replace(
            spectral.models, guide_to_slm=truth(rig).guide_to_slm, guide_info={"source": "truth"}
        )
        path = publish(
            models, rig=rig.description, quality={"checks": [], "residuals": {}},
            procedure=dict(spectral.manifest["procedure"]), data=guided,
        )  # fmt: skip
        bundle = load(path)
    procedure = load_procedure("snapshot_validation")
    stamp = f"bench-{int(time.time())}"
    video = take_snapshots(
        rig, bundle, procedure, scene="natural", session_id=stamp, data=guided, progress=True
    )
    frame = next(reconstruct_snapshots(video, bundle, procedure, progress=False))
    reference = truth(rig).binned_cube(bundle.bin_edges, procedure["snapshot"]["light"], "natural")
    mask = frame.mask
    valid = np.zeros(mask.shape, bool)
    valid[8:-8, 8:-8] = True
    ours = {
        "extraction": _psnr_one_gain(frame.spectra, reference[mask]),
        "rank1": _psnr_one_gain(frame.rank1[valid], reference[valid]),
        "guided": _psnr_one_gain(frame.guided[valid], reference[valid]),
    }
    del frame
    root = data / stamp
    root.mkdir()
    calib = _run(bundle.path, "1/64", root / "calibration")
    capture = _run_child([
        sys.executable, __file__, "--child-capture", str(bundle.path), f"{stamp}", str(guided),
        str(root / "exp1"),
    ])  # fmt: skip
    runner = Path(__file__).parents[1] / "tests" / "export" / "sassi_upstream_run.py"
    theirs = {}
    for label, extra in (("exported", []), ("vsize 3", ["--vsize", "3"])):
        out = root / f"theirs-{label.replace(' ', '')}.npz"
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, str(runner), str(root), "exp1", str(out), *extra],
            check=True, capture_output=True, text=True,
        )  # fmt: skip
        with np.load(out) as cube:
            theirs[label] = {
                "vsize": int(cube["vsize"]),
                "extraction": _psnr_one_gain(cube["cube"][mask], reference[mask]),
                "rank1": _psnr_one_gain(cube["cube_rec"][valid], reference[valid]),
                "seconds": time.perf_counter() - start,
            }
    print(f"rig {rig_name}, bundle {bundle.path}, {int(mask.sum())} open SLM pixels")
    print(_measured("bundle export --format sassi-mat", calib))
    print(_measured("snapshot export --format sassi-mat (vsize chosen)", capture))
    tried = ", ".join(f"{w}: {d:.2f}" for w, d in capture["scores"].items())
    print(f"  vsize {capture['vsize']}; agreement with ours per window (dB): {tried}")
    print("PSNR against the truth (dB; one gain; rank-1 over the SLM less 8 px):")
    for label, score in theirs.items():
        print(
            f"  theirs, vsize {score['vsize']:2d} ({label}): spectra {score['extraction']:.2f}, "
            f"rank-1 {score['rank1']:.2f}  ({score['seconds']:.0f} s)"
        )
    print(
        f"  ours: spectra {ours['extraction']:.2f}, rank-1 {ours['rank1']:.2f}, "
        f"guided {ours['guided']:.2f}"
    )
    shutil.rmtree(root, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bundle", help="bundle folder (default: synthetic prototype)")
    parser.add_argument("--cases", default="exact,1/64,paper,load")
    parser.add_argument("--rig", help="run the authors' code on this virtual bench's exports")
    parser.add_argument("--data", help="with --rig: folder kept between runs (the bundle)")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--child-capture", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        case, bundle_dir, out = args.child
        _child(bundle_dir, case, out)
        return
    if args.child_capture:
        _child_capture(*args.child_capture)
        return
    if args.rig:
        if args.data:
            rig_accuracy(args.rig, Path(args.data))
        else:
            with tempfile.TemporaryDirectory(prefix="bench-sassi-rig-") as tmp:
                rig_accuracy(args.rig, Path(tmp))
        return
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    with tempfile.TemporaryDirectory(prefix="bench-sassi-export-") as tmp:
        root = Path(tmp)
        bundle_dir = Path(args.bundle) if args.bundle else synthetic_prototype(root / "data")
        print(f"bundle {bundle_dir}")
        baseline = None
        for case in cases:
            out = root / ("1-64" if case == "load" else case.replace("/", "-"))
            result = _run(bundle_dir, case, out)
            total = sum(result["sizes"].values())
            if case == "exact":
                baseline = result
            line = (
                f"{case:6s} wall {result['wall_s']:6.1f} s  cpu {result['cpu_s']:6.1f} s  "
                f"peak {result['peak_bytes'] / 1e9:5.2f} GB"
            )
            if total:
                files = ", ".join(f"{k} {v / 1e6:.1f} MB" for k, v in result["sizes"].items())
                line += f"  {files} (total {total / 1e6:.1f} MB"
                if baseline is not None and case != "exact":
                    ratio = total / sum(baseline["sizes"].values())
                    cpu = result["cpu_s"] / baseline["cpu_s"]
                    line += f", {ratio:.2f}x the exact size, {cpu:.2f}x its cpu time"
                line += ")"
            print(line, flush=True)
            if case not in ("1/64",) or "load" not in cases:
                shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
