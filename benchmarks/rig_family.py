"""The default calibration chain on a seeded family of benches, scored against the truth.

Draws ``--count`` rigs of the family (:mod:`sassi_bench.rig.sim.family`: glasses from N-BK7
to SF10/N-SF11, spreads of 40-140 px, SLMs, cameras, contrasts, rotations, 4-6 lasers,
with and without lamps, each built off its description by a datasheet's tolerance), runs
``sassi-bench calibrate``'s chain on each with the shipped procedures (every rig in its own
process and data root, publishing with ``allow_failed`` so a failing bundle is scored
too), and prints per rig whether it published (every check passed) and its accuracy
against the bench's truth: the worst laser's correspondence RMS (px), the streak rows'
RMS over the field and band (px), the wavelength map's RMS and largest error over the
field (nm), the Macbeth mean dE00, and the chart
scan's PSNR against the truth cube (dB); the ``--out`` records also keep the response's
frames and stated 1-sigma (``response``). It ends with the line
``rig family: P of N published within the targets`` (0.1 px, rows 0.1 px, 0.3 nm, dE00 0.5,
45 dB).

Run: ``python benchmarks/rig_family.py --small`` (24 small rigs, 3-6 minutes each on two
busy cores); ``--only 3 9`` runs some rigs; ``--out family.jsonl`` keeps the results,
and a second run skips the rigs already in it; each rig's frames are removed once it is
scored (``--keep-data`` keeps them); ``--table family.jsonl`` prints the table
(``--update-docs`` also writes it to ``docs/_data/rig_family.json`` for the docs, with
``--small``, or ``rig_family_full.json``).
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np
import yaml

#: The targets: correspondence px (worst laser), streak rows px RMS, wavelength nm RMS,
#: Macbeth mean dE00, scan dB.
TARGETS = {"corr_px": 0.1, "row_px": 0.1, "wl_nm": 0.3, "de00": 0.5, "scan_db": 45.0}
TARGETS_TEXT = (
    f"{TARGETS['corr_px']:g} px, rows {TARGETS['row_px']:g} px, {TARGETS['wl_nm']:g} nm, "
    f"dE00 {TARGETS['de00']:g}, {TARGETS['scan_db']:g} dB"
)


def within_targets(record: dict) -> bool:
    """Published, and every figure within its target."""
    if record.get("outcome") != "published":
        return False
    for key, limit in TARGETS.items():
        value = record.get(key)
        if value is None or not np.isfinite(value):
            return False
        if (value < limit) if key == "scan_db" else (value > limit):
            return False
    return True


def on_target(record: dict) -> bool | None:
    """Whether the bundle's figures are all within the targets, whatever its checks said;
    None when there is no bundle to score (refused, crashed)."""
    if "wl_nm" not in record:
        return None
    return within_targets({**record, "outcome": "published"})


def checks_verdict(record: dict) -> str:
    """Whether the bundle's checks judged it right: a bundle on target that passes and one
    off target that fails are both right; the other two are the checks' errors."""
    scored = on_target(record)
    if scored is None:
        return "no bundle"
    published = record.get("outcome") == "published"
    if scored == published:
        return "right"
    return "passed off target" if published else "failed on target"


def score(rig, result) -> dict:
    """The chain's models against the bench's truth (as ``accuracy_table.py`` scores them)."""
    from accuracy_table import _chart_scan_scores

    from sassi_bench.bundle import load
    from sassi_bench.bundle.jsonio import thaw
    from sassi_bench.rig.sim import truth

    t = truth(rig)
    cal = result.stages["spectral"]
    corr = 0.0
    for d in cal.lasers:
        x, y = t.slm_to_camera(d.slm_u, d.slm_v, t.laser_centre_nm(d.wavelength_nm))
        corr = max(corr, float(np.sqrt(np.mean((x - d.camera_x) ** 2 + (y - d.camera_y) ** 2))))
    error = t.wavelength_map_error_nm(cal.dispersion.model)
    rows = t.row_error_px(cal.dispersion.model)
    out = {
        "corr_px": corr,
        "wl_nm": float(np.sqrt(np.mean(error**2))),
        "wl_max_nm": float(np.abs(error).max()),
        "stated_nm": float(cal.dispersion.position_sigma_nm),
        "stated_rms_nm": float(cal.dispersion.position_sigma_rms_nm),
        "stated_px": float(cal.dispersion.position_sigma_px),
        "stated_rms_px": float(cal.dispersion.position_sigma_rms_px),
        "line_sigma_nm": float(cal.dispersion.line_sigma_nm),
        "row_px": float(np.sqrt(np.mean(rows**2))),
        "row_max_px": float(np.abs(rows).max()),
        "de00": float(result.stages["macbeth"].summary()["mean_de00"]),
    }
    bundle = load(result.bundle_path)
    taken = thaw(bundle.manifest["quality"]["residuals"]["response"]["response_frames"])
    out["response"] = {k: taken[k] for k in ("frames", "outcome", "de00_sigma", "sigma_relative")}
    out["response"]["batches"] = taken["batches"]
    chart = result.stages["macbeth"].settings["chart_session"]
    scores, _ = _chart_scan_scores(rig, bundle, result.stages["staging"], chart)
    out["scan_db"] = float(scores.split(" dB")[0])
    return out


def run_one(rig_file: Path, data: Path) -> dict:
    """One rig through the chain, scored; a refusal or a crash is a record too."""
    from sassi_bench import open_rig
    from sassi_bench.errors import SassiBenchError
    from sassi_bench.procedure import load_procedure
    from sassi_bench.workflows.full import run_full_calibration

    record: dict = {"rig": rig_file.stem}
    start = time.perf_counter()
    try:
        rig = open_rig(str(rig_file))
        result = run_full_calibration(
            rig, load_procedure("full_calibration"), session_id="family", data=data,
            progress=False, allow_failed=True,
        )  # fmt: skip
        record["outcome"] = "published" if result.passed else "failed"
        record["failed"] = [c.describe() for c in result.checks if not c.passed]
        record.update(score(rig, result))
    except SassiBenchError as exc:
        record["outcome"] = "refused"
        record["error"] = str(exc)
    except Exception as exc:  # a crash is a result of the benchmark too
        record["outcome"] = "crashed"
        record["error"] = f"{type(exc).__name__}: {exc}"
        record["traceback"] = traceback.format_exc()[-2000:]
    record["time_s"] = round(time.perf_counter() - start, 1)
    record["within_targets"] = within_targets(record)
    return record


def _cause(r: dict) -> str:
    if r["outcome"] in ("refused", "crashed"):
        return r["error"].split(". Fix:")[0][:120]
    bits = [f.split(" (")[0] for f in r.get("failed", [])]
    for key, limit in TARGETS.items():
        value = r.get(key)
        if value is not None and ((value < limit) if key == "scan_db" else (value > limit)):
            bits.append(f"{key} off target")
    return "; ".join(bits) or "-"


def print_table(records: list[dict]) -> None:
    """The per-rig table and the family's line."""

    def f(r: dict, key: str, fmt: str) -> str:
        return fmt.format(r[key]) if r.get(key) is not None else "-"

    print(
        "| rig | outcome | checks | corr px | wavelength nm RMS (max) | stated nm RMS (worst) | "
        "rows px RMS (max) | dE00 | scan dB | time s | cause |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in records:
        wl = f"{r['wl_nm']:.3f} ({r['wl_max_nm']:.3f})" if "wl_nm" in r else "-"
        print(
            f"| {r['rig']} | {r['outcome']} | {checks_verdict(r)} | {f(r, 'corr_px', '{:.3f}')} | "
            f"{wl} | {_stated(r)} | {_rows(r)} | "
            f"{f(r, 'de00', '{:.2f}')} | {f(r, 'scan_db', '{:.1f}')} | {r['time_s']} | "
            f"{_cause(r)} |"
        )
    ok = sum(within_targets(r) for r in records)
    verdicts = [checks_verdict(r) for r in records]
    print(f"\nrig family: {ok} of {len(records)} published within the targets ({TARGETS_TEXT})")
    print(
        f"checks: right on {verdicts.count('right')} of {len(records)} "
        f"({verdicts.count('passed off target')} passed off target, "
        f"{verdicts.count('failed on target')} failed on target, "
        f"{verdicts.count('no bundle')} without a bundle)"
    )


def _response_frames(r: dict) -> str:
    """The response's pinhole frames from a record (older records keep none)."""
    response = r.get("response")
    if isinstance(response, str):
        response = ast.literal_eval(response)
    return str(response["frames"]) if isinstance(response, dict) else "-"


def _stated(r: dict) -> str:
    """The map's stated 1-sigma, RMS over the band (worst), nm (older records keep none)."""
    if r.get("stated_rms_nm") is None:
        return "-"
    return f"{r['stated_rms_nm']:.3f} ({r['stated_nm']:.3f})"


def _rows(r: dict) -> str:
    """The model's streak rows against the truth, RMS (max) px (older records keep none)."""
    return f"{r['row_px']:.4f} ({r['row_max_px']:.3f})" if r.get("row_px") is not None else "-"


#: The docs table's columns: a figure of each rig's record.
DOC_COLUMNS = (
    "outcome",
    "checks",
    "corr px",
    "wavelength nm RMS (max)",
    "stated nm RMS (worst)",
    "rows px RMS (max)",
    "dE00",
    "scan dB",
    "response frames",
    "time s",
)


def write_docs_table(records: list[dict], small: bool) -> Path:
    """The per-rig table into ``docs/_data/rig_family.json`` (small rigs) or
    ``rig_family_full.json`` (one row per rig, the family's line last), which
    ``python benchmarks/figures.py`` puts into ``docs/rig_family.md``."""
    from figures import update_columns

    def f(r: dict, key: str, fmt: str) -> str:
        return fmt.format(r[key]) if r.get(key) is not None else "-"

    cells = {}
    for r in records:
        wl = f"{r['wl_nm']:.3f} ({r['wl_max_nm']:.3f})" if "wl_nm" in r else "-"
        cells[r["rig"]] = {
            "outcome": r["outcome"],
            "checks": checks_verdict(r),
            "corr px": f(r, "corr_px", "{:.3f}"),
            "wavelength nm RMS (max)": wl,
            "stated nm RMS (worst)": _stated(r),
            "rows px RMS (max)": _rows(r),
            "dE00": f(r, "de00", "{:.2f}"),
            "scan dB": f(r, "scan_db", "{:.1f}"),
            "response frames": _response_frames(r),
            "time s": f(r, "time_s", "{:.0f}"),
        }
    ok = sum(within_targets(r) for r in records)
    cells["rig family"] = {"outcome": f"{ok} of {len(records)} published within the targets"}
    rows = list(cells)
    columns = [
        {"key": name, "values": {rig: row[name] for rig, row in cells.items() if name in row}}
        for name in DOC_COLUMNS
    ]
    return update_columns(
        "rig_family" if small else "rig_family_full",
        f"The default chain on the family's {'small' if small else 'full-size'} rigs, "
        "scored against the virtual bench's "
        f"truth (targets {TARGETS_TEXT})",
        rows,
        columns,
        row_label="rig",
        replace=True,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=45)
    parser.add_argument("--count", type=int, default=24)
    parser.add_argument(
        "--small",
        action="store_true",
        help="small SLMs (the fast subset); with --table, which docs table to write",
    )
    parser.add_argument("--keep-data", action="store_true", help="keep each rig's captured frames")
    parser.add_argument("--only", type=int, nargs="+", help="indices of the rigs to run")
    parser.add_argument("--out", help="JSON lines of the results (resumable)")
    parser.add_argument("--table", help="print the table of a results file and stop")
    parser.add_argument(
        "--update-docs",
        action="store_true",
        help="with --table: also write docs/_data/rig_family.json",
    )
    parser.add_argument("--one", nargs=2, metavar=("RIG", "DATA"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(Path(args.one[0]), Path(args.one[1])), default=str))
        return 0
    if args.table:
        records = [json.loads(x) for x in Path(args.table).read_text().splitlines() if x]
        print_table(records)
        if args.update_docs:
            path = write_docs_table(records, small=args.small)
            print(f"wrote {path}; `python benchmarks/figures.py` rewrites docs/rig_family.md")
        return 0
    from sassi_bench.rig.sim.family import family_rigs

    rigs = family_rigs(args.seed, args.count, small=args.small)
    chosen = [r for i, r in enumerate(rigs) if args.only is None or i in args.only]
    out = Path(args.out) if args.out else None
    done = {}
    if out is not None and out.exists():
        done = {json.loads(x)["rig"]: json.loads(x) for x in out.read_text().splitlines() if x}
    records = []
    with tempfile.TemporaryDirectory(prefix="rig-family-") as tmp:
        for rig in chosen:
            if rig["name"] in done:
                records.append(done[rig["name"]])
                continue
            rig_file = Path(tmp) / f"{rig['name']}.yaml"
            rig_file.write_text(yaml.safe_dump(rig, sort_keys=False))
            data = Path(tmp) / rig["name"]
            env = dict(os.environ, SASSI_BENCH_DATA=str(data))
            print(f"[{time.strftime('%H:%M:%S')}] {rig['name']}", file=sys.stderr, flush=True)
            run = subprocess.run(
                [sys.executable, __file__, "--one", str(rig_file), str(data)],
                env=env, capture_output=True, text=True, check=False,
            )  # fmt: skip
            lines = [x for x in run.stdout.splitlines() if x.startswith("{")]
            record = (
                json.loads(lines[-1])
                if lines
                else {"rig": rig["name"], "outcome": "crashed", "time_s": 0,
                      "error": run.stderr[-300:], "within_targets": False}
            )  # fmt: skip
            records.append(record)
            if not args.keep_data:  # a full-size rig's frames fill gigabytes
                shutil.rmtree(data, ignore_errors=True)
            if out is not None:
                with out.open("a") as f:
                    f.write(json.dumps(record, default=str) + "\n")
    print_table(records)
    return 0


if __name__ == "__main__":
    sys.exit(main())
