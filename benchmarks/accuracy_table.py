"""The README's accuracy table: the whole chain on a bench as described and as built.

Runs ``sassi-bench calibrate`` (spectral sweeps and fits, radiometric response, guide
homography, Macbeth validation) on the default ``sim`` rig, on the test rig with every
as-built deviation (``tests/rigs/as-built-all.yaml``: a laser 2.8 nm off its label,
another glass melt and prism apex, a hotter halogen lamp, another LED, another guide
sensor, another SLM gamma), with the spectral procedure's
``fit.estimate_laser_wavelengths`` on, and on the same rig with every nuisance as well
(``tests/rigs/all-deviations.yaml``), and scores every model against the bench's truth.
Prints a Markdown table, one column per rig. Each rig runs in its own process.

Run: ``python benchmarks/accuracy_table.py [--rigs sim tests/rigs/as-built-all.yaml]``
(about 3 minutes a rig on two quiet cores).
"""

from __future__ import annotations

import argparse
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.calibrate.guide_registration import field_discrepancy_px
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.full import run_full_calibration
from sassi_bench.workflows.procedure import load_procedure

ROOT = Path(__file__).resolve().parents[1]
RIGS = [
    "sim",
    *(str(ROOT / "tests" / "rigs" / f"{n}.yaml") for n in ("as-built-all", "all-deviations")),
]


def accuracy_procedure(procedure: dict, folder: Path) -> dict:
    """The full-calibration ``procedure`` with the spectral stage estimating laser
    wavelengths (its procedure file is written to ``folder``)."""
    spectral = load_procedure("spectral_calibration")
    spectral["fit"]["estimate_laser_wavelengths"] = True
    spectral.pop("source", None)
    spectral_path = Path(folder) / "spectral.yaml"
    spectral_path.write_text(yaml.safe_dump(spectral))
    return {**procedure, "spectral_procedure": str(spectral_path)}


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
    estimated = cal.dispersion.estimated_lines
    if estimated:
        laser = ", ".join(
            f"{label:g} nm at {cal.dispersion.wavelengths_nm[label]:.2f} "
            f"(true {t.laser_centre_nm(label):.2f})"
            for label in estimated
        )
    else:
        agree = max(abs(line.offset_nm) for line in cal.laser_lines.values())
        laser = f"none off label (max {agree:.3f} nm)"
    band = np.linspace(420, 690, 28)
    blur = float(np.abs(cal.blur.model.sigma(band) - t.line_spread_sigma_px(band)).max())
    guide_rms, _ = field_discrepancy_px(bundle.guide_to_slm, t.guide_to_slm, rig.slm.shape)
    relative = np.asarray(bundle.response) / t.relative_response(bundle.bin_edges)
    relative /= np.median(relative)
    wl = bundle.wavelengths
    core = (wl > 410) & (wl < 640)
    lamp = bundle.manifest["quality"]["residuals"]["response"]["lamp_temperature_sensitivity"]
    summary = result.stages["macbeth"].summary()
    failed = [c.name for c in result.checks if not c.passed]
    return {
        "rig": rig.description.name,
        "all checks pass": "yes" if not failed else "no: " + ", ".join(failed),
        "correspondences vs truth (worst laser RMS)": f"{corr_rms:.3f} px",
        "laser line fitted at an estimate": laser,
        "wavelength map vs truth (RMS / max)": f"{map_rms:.3f} / {map_max:.3f} nm",
        "blur width vs truth (max, 420-690 nm)": f"{blur:.3f} px",
        "guide homography vs truth (RMS over the SLM)": f"{guide_rms:.3f} px",
        "response vs truth (max, 410-640 nm)": f"{100 * np.abs(relative[core] - 1).max():.1f} %",
        "response change for a lamp +-100 K off (max)": (
            f"{100 * lamp['max_relative_change']:.1f} %"
        ),
        "Macbeth mean dE00 / spectral angle": (
            f"{summary['mean_de00']:.2f} / {summary['mean_spectral_angle_deg']:.2f} deg"
        ),
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
    args = parser.parse_args()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        columns = list(pool.map(measure, args.rigs))
    print(markdown(columns))


if __name__ == "__main__":
    main()
