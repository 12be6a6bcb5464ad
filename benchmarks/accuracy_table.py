"""The README's accuracy table: the whole chain on a bench as described and as built.

Runs ``sassi-bench calibrate`` (spectral sweeps and fits, radiometric response, guide
homography, Macbeth validation) on the default ``sim`` rig, on two rigs with other prisms
(``tests/rigs/prism-nbk7.yaml``: a low-dispersion N-BK7 prism of 66 px, the relay rotated
1.2 degrees, a wider blur, a Nikon guide sensor; ``tests/rigs/prism-sf10.yaml``: an SF10
flint of 68 px, rotated -0.6 degrees, a four-point blur curve), on the test rig with every
as-built deviation (``tests/rigs/as-built-all.yaml``: a laser 2.8 nm off its label,
another glass melt and prism apex, a hotter halogen lamp, another LED, another guide
sensor, another SLM gamma), with the spectral procedure's
``fit.estimate_laser_wavelengths`` on, and on the same rig with every nuisance as well
(``tests/rigs/all-deviations.yaml``), and scores every model against the bench's truth,
the chart scan (re-assembled from the chain's session) too: its PSNR and per-band PSNR
against the truth cube, and the Macbeth patches with the steepest spectral edges beside
their noise floors.
Prints a Markdown table, one column per rig, and writes each rig's column, with the date,
the machine and the command, into ``docs/_data/accuracy.json`` (the table the README and
the accuracy page quote; ``python benchmarks/figures.py`` then rewrites the README's
copy). Each rig runs in its own process.

The optical-design rigs (``sim-achromat``, ``sim-singlet``: ``--rigs sim sim-achromat
sim-singlet``) take the plans their optics give, as every rig does, and their blur is
scored over the field along and across the streak.

Run: ``python benchmarks/accuracy_table.py [--rigs sim tests/rigs/as-built-all.yaml]
[--no-update]`` (about 3 minutes a rig on two quiet cores).
"""

from __future__ import annotations

import argparse
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml
from figures import update_columns

from sassi_bench import open_rig
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.calibrate.guide_registration import field_discrepancy_px
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.scan import assemble_scan
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.full import run_full_calibration

ROOT = Path(__file__).resolve().parents[1]
RIGS = [
    "sim",
    *(
        str(ROOT / "tests" / "rigs" / f"{n}.yaml")
        for n in ("as-built-all", "all-deviations", "prism-nbk7", "prism-sf10")
    ),
]

#: The chart patches with the steepest spectral edges, reported one by one.
EDGE_PATCHES = ("red", "magenta", "blue")


def _chart_scan_scores(rig, bundle, staging: Path, session_id: str) -> tuple[str, str]:
    """The chain's chart scan re-assembled with the bundle, against the bench's truth:
    PSNR / mean spectral angle, and the per-band PSNR in mid band and at the red end."""
    t = truth(rig)
    scan = assemble_scan(Session.open(session_id, data=staging), bundle, progress=False)
    expected = t.binned_cube(bundle.bin_edges, "led", "colorchecker")
    good = scan.quality == 0
    a, b = scan.cube[good].astype(np.float64), expected[good]
    cosine = (a * b).sum(1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    gain = (a * b).sum() / (b * b).sum()
    square = (a - gain * b) ** 2
    peak = (gain * b).max()
    psnr = 10 * np.log10(peak**2 / square.mean())
    band = 10 * np.log10(peak**2 / square.mean(axis=0))
    wl = bundle.wavelengths
    mid, red = band[(wl > 500) & (wl < 600)].mean(), band[wl > 650].mean()
    return f"{psnr:.2f} dB / {angle.mean():.3f} deg", f"{mid:.1f} / {red:.1f} dB"


def accuracy_procedure(procedure: dict, folder: Path) -> dict:
    """The full-calibration ``procedure`` with the spectral stage estimating laser
    wavelengths (its procedure file is written to ``folder``)."""
    spectral = load_procedure("spectral_calibration")
    spectral["fit"]["estimate_laser_wavelengths"] = True
    spectral.pop("source", None)
    spectral_path = Path(folder) / "spectral.yaml"
    spectral_path.write_text(yaml.safe_dump(spectral))
    return {**procedure, "spectral_procedure": str(spectral_path)}


def _count(n: int) -> str:
    """``n`` in words up to ten, as the table reads."""
    words = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine")
    return words[n] if n < len(words) else str(n)


def laser_cell(cal, t) -> str:
    """The table's laser cell: with lamps, how many lines the anchored fit put at their
    true wavelengths and how close; else the lines fitted at an estimate (or how far the
    others put any line from its label). ``cal`` a spectral calibration result, ``t`` the
    bench's truth."""
    estimated = cal.dispersion.estimated_lines
    used = cal.dispersion.wavelengths_nm
    if cal.dispersion.anchored:
        worst = max(abs(used[label] - t.laser_centre_nm(label)) for label in used)
        lines = _count(len(used))
        return f"lamp-anchored: all {lines} at their true lines (within {worst:.3f} nm)"
    if estimated:
        return ", ".join(
            f"{label:g} nm at {used[label]:.2f} (true {t.laser_centre_nm(label):.2f})"
            for label in estimated
        )
    agree = max(abs(line.offset_nm) for line in cal.laser_lines.values())
    return f"none off label (max {agree:.3f} nm)"


def score(rig, result) -> dict[str, str]:
    """Every model of a finished chain (``run_full_calibration``) against the bench's truth."""
    t = truth(rig)
    bundle = load(result.bundle_path)
    cal = result.stages["spectral"]
    corr_rms = 0.0
    for d in cal.lasers:
        x, y = t.slm_to_camera(d.slm_u, d.slm_v, t.laser_centre_nm(d.wavelength_nm))
        error = np.hypot(x - d.camera_x, y - d.camera_y)
        corr_rms = max(corr_rms, float(np.sqrt(np.mean(error**2))))
    error_nm = t.wavelength_map_error_nm(cal.dispersion.model)
    map_rms, map_max = float(np.sqrt(np.mean(error_nm**2))), float(np.abs(error_nm).max())
    laser = laser_cell(cal, t)
    band = np.linspace(420, 690, 28)
    # The blur leaves the camera pixel to its users: compare the spot widths it predicts a
    # camera measures, along and across the streak, over the field (9 x 5 points).
    h, w = rig.slm.shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 5))
    u, v, lam = u.ravel()[:, None], v.ravel()[:, None], band[None, :]
    spot = cal.blur.model.spot(u, v, lam)
    cxx, cyy, _ = t.spot_covariance(u, v, lam)
    pixel = 1.0 / 12.0
    blur = max(
        float(np.abs(np.sqrt(spot.along**2 + pixel) - np.sqrt(cxx)).max()),
        float(np.abs(np.sqrt(spot.across**2 + pixel) - np.sqrt(cyy)).max()),
    )
    # ... and over the whole band, where the blue end leans on the lamp lines' spots
    whole = np.linspace(400, 700, 31)[None, :]
    spot = cal.blur.model.spot(u, v, whole)
    cxx, cyy, _ = t.spot_covariance(u, v, whole)
    whole_along = float(np.abs(np.sqrt(spot.along**2 + pixel) - np.sqrt(cxx)).max())
    whole_across = float(np.abs(np.sqrt(spot.across**2 + pixel) - np.sqrt(cyy)).max())
    guide_rms, _ = field_discrepancy_px(bundle.guide_to_slm, t.guide_to_slm, rig.slm.shape)
    relative = np.asarray(bundle.response) / t.relative_response(bundle.bin_edges)
    relative /= np.median(relative)
    wl = bundle.wavelengths
    core = (wl > 410) & (wl < 640)
    wide = (wl > 410) & (wl < 690)
    lamp = bundle.manifest["quality"]["residuals"]["response"]["lamp_temperature_sensitivity"]
    macbeth = result.stages["macbeth"]
    summary = macbeth.summary()
    names = [n.lower() for n in macbeth.patch_names]
    edges = " / ".join(
        f"{macbeth.rmse[names.index(p)]:.4f} ({macbeth.noise['rmse'][names.index(p)]:.4f})"
        for p in EDGE_PATCHES
    )
    scan_scores, band_psnr = _chart_scan_scores(
        rig, bundle, result.stages["staging"], macbeth.settings["chart_session"]
    )
    failed = [c.name for c in result.checks if not c.passed]
    return {
        "rig": rig.description.name,
        "all checks pass": "yes" if not failed else "no: " + ", ".join(failed),
        "correspondences vs truth (worst laser RMS)": f"{corr_rms:.3f} px",
        "laser line fitted at an estimate": laser,
        "wavelength map vs truth (RMS / max)": f"{map_rms:.3f} / {map_max:.3f} nm",
        "blur width vs truth (max over the field, 420-690 nm)": f"{blur:.3f} px",
        "blur width vs truth, along / across (max over the field, 400-700 nm)": (
            f"{whole_along:.3f} / {whole_across:.3f} px"
        ),
        "guide homography vs truth (RMS over the SLM)": f"{guide_rms:.3f} px",
        "response vs truth (max, 410-640 nm)": f"{100 * np.abs(relative[core] - 1).max():.1f} %",
        "response vs truth (max, 410-690 nm)": f"{100 * np.abs(relative[wide] - 1).max():.1f} %",
        "response change for a lamp +-100 K off (max)": (
            f"{100 * lamp['max_relative_change']:.1f} %"
        ),
        "Macbeth mean dE00 / spectral angle": (
            f"{summary['mean_de00']:.2f} / {summary['mean_spectral_angle_deg']:.2f} deg"
        ),
        "Macbeth red / magenta / blue RMSE (noise floor)": edges,
        "chart scan vs truth: PSNR / mean angle": scan_scores,
        "chart scan per-band PSNR, 500-600 / > 650 nm": band_psnr,
    }


def measure(rig_name: str) -> dict[str, str]:
    """Run the chain on one rig and score it against the bench's truth."""
    rig = open_rig(rig_name)
    with tempfile.TemporaryDirectory(prefix="accuracy-") as tmp:
        procedure = accuracy_procedure(load_procedure("full_calibration"), Path(tmp))
        result = run_full_calibration(
            rig, procedure, session_id="accuracy", data=tmp, progress=False, allow_failed=True
        )
        return score(rig, result)


def markdown(columns: list[dict[str, str]]) -> str:
    """The table: one row per figure, one column per rig."""
    lines = [
        "| | " + " | ".join(f"`{c['rig']}`" for c in columns) + " |",
        "| --- |" + " --- |" * len(columns),
    ]
    for key in columns[0]:
        if key != "rig":
            lines.append(f"| {key} | " + " | ".join(c[key] for c in columns) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rigs", nargs="+", default=RIGS)
    parser.add_argument("--jobs", type=int, default=2, help="rigs run at once")
    parser.add_argument(
        "--no-update", action="store_true", help="print only: leave docs/_data/accuracy.json"
    )
    args = parser.parse_args()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        columns = list(pool.map(measure, args.rigs))
    print(markdown(columns))
    if not args.no_update:
        rows = [key for key in columns[0] if key != "rig"]
        path = update_columns(
            "accuracy",
            "The whole chain on a bench as described and as built, scored against the "
            "virtual bench's truth",
            rows,
            [{"key": c["rig"], "values": {k: c[k] for k in rows}} for c in columns],
            code_keys=True,
        )
        print(f"wrote {path}; `python benchmarks/figures.py` rewrites the README's copy")


if __name__ == "__main__":
    main()
