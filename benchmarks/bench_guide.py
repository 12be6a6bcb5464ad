"""Guide registration: the coarse scan routes against the full Nyquist scan.

For each pinhole-offset stride (full scan ``1x1`` first, then coarser routes) this runs
the guide registration workflow on the virtual bench (scan, rendering, guide capture,
fit; nothing published) and prints the frames, the wall time as a ratio to the full
scan's, and the accuracy against the bench's true homography (RMS and maximum over a
grid spanning the SLM), for the default guide camera and for one rotated by 3 degrees at
0.8 guide px per SLM px (registered against the same rendering). Feature-only fits (no
ECC refinement) are shown beside the default.

A bundle for the rig is needed: ``--bundle PATH``, or the spectral calibration runs first.

Run: ``python benchmarks/bench_guide.py [--rig sim] [--strides 1x1 2x1 4x1 10x1] [--bundle DIR]``
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time

from _bundle import bundle_for

from sassi_bench import open_rig
from sassi_bench.calibrate.guide_registration import (
    RegistrationError,
    field_discrepancy_px,
    register_guide,
)
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.guide import capture_guide, run_guide_registration


def _accuracy(rig, result, proc, data, tag: str) -> tuple[float, float, float]:
    """(RMS, max) of the workflow's homography and RMS of a feature-only fit, SLM px."""
    h_true = truth(rig).guide_to_slm
    rms, worst = field_discrepancy_px(result.homography, h_true, rig.slm.shape)
    guide, valid, _ = capture_guide(
        rig, proc, session_id=f"features-{tag}", data=data, progress=False
    )
    ref = result.reference
    sparse = register_guide(
        guide, ref.image, slm_valid=ref.valid, guide_valid=valid, dense=False,
        sift_options={"contrastThreshold": proc["match"]["contrast_threshold"]},
    )  # fmt: skip
    return rms, worst, field_discrepancy_px(sparse.homography, h_true, rig.slm.shape)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", default="sim")
    parser.add_argument("--strides", nargs="+", default=["1x1", "2x1", "4x1", "10x1"])
    parser.add_argument("--bundle", help="bundle folder for the rig (default: calibrate first)")
    args = parser.parse_args()
    rig = open_rig(args.rig)
    turned = copy.deepcopy(rig.description.to_dict())
    turned["guide_camera"].update(rotation_deg=3.0, scale=0.8, homography=None)
    rotated = open_rig(rig_description_from_dict(turned))
    with tempfile.TemporaryDirectory() as data:
        bundle = bundle_for(rig, args.bundle, data)
        print(
            f"{'stride':>7} {'frames':>6} {'time':>8} {'ratio':>6} | default rig: rms  max  "
            "(features only) | rotated 3 deg, x0.8: rms  max  (features only)"
        )
        baseline = None
        for text in args.strides:
            sx, sy = (int(x) for x in text.split("x"))
            proc = load_procedure("guide_registration")
            proc["scan"]["stride_px"] = [sx, sy]
            start = time.perf_counter()
            try:
                result = run_guide_registration(
                    rig, bundle, proc, session_id=f"s{sx}x{sy}", data=data, progress=False,
                    publish_bundle=False,
                )  # fmt: skip
            except RegistrationError as exc:  # too coarse: say so and go on
                print(f"{text:>7}  registration failed: {str(exc).split('. Fix:')[0]}")
                continue
            seconds = time.perf_counter() - start
            baseline = baseline or seconds
            frames = len(result.reference.session.plan.select(role="pinholes"))
            rms, worst, sparse = _accuracy(rig, result, proc, data, f"d{sx}x{sy}")
            other = run_guide_registration(
                rotated, bundle, proc, reference=result.reference, session_id=f"r{sx}x{sy}",
                data=data, progress=False, publish_bundle=False,
            )  # fmt: skip
            r_rms, r_worst, r_sparse = _accuracy(rotated, other, proc, data, f"r{sx}x{sy}")
            print(
                f"{text:>7} {frames:>6} {seconds:>7.1f}s {seconds / baseline:>6.2f} | "
                f"{rms:.3f} {worst:.3f} ({sparse:.3f}) | {r_rms:.3f} {r_worst:.3f} ({r_sparse:.3f})"
            )


if __name__ == "__main__":
    main()
