"""Pattern swap time of the SLM display window.

Shows random 8-bit patterns full screen with :class:`DisplaySlm` and times each
``show`` (copy into the window's image, synchronous repaint, flush to the X server),
at the sim rig's SLM size and at the prototype's (1920x1080). Each time is also
printed as a ratio to a baseline measured in the same run: a numpy copy of the same
frame, the least any swap must do.

Without ``--monitor`` it starts a dummy dual-head Xorg (as the tests do; needs
xserver-xorg-video-dummy and xrandr) and uses its second monitor; with ``--monitor``
it uses that monitor of the current desktop.

Run: ``python benchmarks/bench_slm_display.py [--swaps 200] [--monitor HDMI-1]``
"""

from __future__ import annotations

import argparse
import functools
import importlib.util
import os
import tempfile
import time
from pathlib import Path

import numpy as np

SIZES = {"sim (640x400)": (400, 640), "prototype (1920x1080)": (1080, 1920)}


def _dummy_x(shape: tuple[int, int]):
    path = Path(__file__).resolve().parents[1] / "tests" / "rig" / "hardware" / "xserver.py"
    spec = importlib.util.spec_from_file_location("bench_xserver", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    reason = module.xorg_missing()
    if reason:
        raise SystemExit(f"cannot start a dummy X server: {reason}")
    server = module.DummyXServer(Path(tempfile.mkdtemp()), (shape[1], shape[0]))
    os.environ["DISPLAY"] = server.display
    return server


def _per_call(fn, frames, repeat: int) -> float:
    fn(frames[0])
    start = time.perf_counter()
    for i in range(repeat):
        fn(frames[i % len(frames)])
    return (time.perf_counter() - start) / repeat


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--swaps", type=int, default=200)
    parser.add_argument("--monitor", default=None, help="monitor of the current desktop")
    args = parser.parse_args()
    from sassi_bench.rig.hardware.slm_display import DisplaySlm

    rng = np.random.default_rng(0)
    print(f"{'SLM':<24}{'swap ms':>10}{'copy ms':>10}{'ratio':>8}")
    for label, shape in SIZES.items():
        server = _dummy_x(shape) if args.monitor is None else None
        try:
            slm = DisplaySlm(shape, monitor=args.monitor if args.monitor else "DUMMY1")
            frames = [rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(8)]
            target = np.empty(shape, np.uint8)
            swap = _per_call(slm.show, frames, args.swaps)
            copy = _per_call(functools.partial(np.copyto, target), frames, args.swaps * 10)
            print(f"{label:<24}{swap * 1e3:>10.2f}{copy * 1e3:>10.3f}{swap / copy:>8.0f}")
            slm.close()
        finally:
            if server is not None:
                import shiboken6
                from PySide6 import QtWidgets

                app = QtWidgets.QApplication.instance()
                if app is not None:
                    shiboken6.delete(app)
                server.close()


if __name__ == "__main__":
    main()
