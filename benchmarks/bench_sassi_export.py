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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bundle", help="bundle folder (default: synthetic prototype)")
    parser.add_argument("--cases", default="exact,1/64,paper,load")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        case, bundle_dir, out = args.child
        _child(bundle_dir, case, out)
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
