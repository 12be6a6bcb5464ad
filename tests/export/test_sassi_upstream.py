"""The SASSI authors' published code, unmodified, on our exports, scored against the
virtual bench's truth.

Their ``cassi.py`` and ``filtering.py`` ship in ``sassi_bench/export/sassi_upstream/``
(the export runs their extraction to choose ``vsize``); the rest of what ``cassi.py``
imports is in ``tests/export/vendored_sassi/`` (``cassi_cp.pyx``, compiled here with
their flags, ``hyperspectral.py``, ``utils.py``, ``this_path.py``), all byte-identical to
Image-Science-Lab-cmu/SASSI at commit 77d27e3, MIT licence beside them.
``sassi_upstream_run.py`` runs the Python block of the export's ``README.txt`` verbatim
in a process of its own.

Scores: PSNR against the bench's true cube at the bundle's bins after one least-squares
gain for the whole cube, over the SLM pixels 8 or more from its edges (the snapshot
procedure's ``scoring.border_px``); for the spectra, over the open pixels.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.export.sassi_code import (
    UPSTREAM_BLOBS,
    UPSTREAM_FOLDER,
    git_blob_id,
    upstream_extraction,
)
from sassi_bench.rig.sim import truth

HERE = Path(__file__).parent
VENDORED = HERE / "vendored_sassi"
#: Git blob ids at upstream commit 77d27e38ef8da24f522d66fd4cc5a5e0b674bb16.
TEST_BLOBS = {
    "modules/cassi_cp.pyx": "1466f52c7c2e5231fe335379e931249d81318d9d",
    "modules/hyperspectral.py": "eb66cca190e599707cad03a9be6af1ef5fcd5875",
    "modules/utils.py": "9d5e647de7efb18e9525be1e5ca88b7665d43b44",
    "modules/this_path.py": "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391",
    "LICENSE": "c8b7f326fbb586b5d7f84168c9a17bed43252461",
}
#: What their code imports beyond this package's dependencies (all from the package index).
THEIR_IMPORTS = ("torch", "cupy", "fast_slic", "sklearn", "Cython")
BORDER_PX = 8


def psnr_one_gain(estimate, reference) -> float:
    """PSNR (dB) after one least-squares gain on the reference (peak: its scaled max)."""
    est = np.asarray(estimate, np.float64)
    ref = np.asarray(reference, np.float64)
    gain = (est * ref).sum() / (ref * ref).sum()
    return float(10 * np.log10((gain * ref).max() ** 2 / np.mean((est - gain * ref) ** 2)))


def test_the_vendored_files_are_upstream_byte_for_byte():
    for name, blob in UPSTREAM_BLOBS.items():
        assert git_blob_id((UPSTREAM_FOLDER / name).read_bytes()) == blob, name
    for name, blob in TEST_BLOBS.items():
        assert git_blob_id((VENDORED / name).read_bytes()) == blob, name


def missing_imports() -> list[str]:
    return [name for name in THEIR_IMPORTS if importlib.util.find_spec(name) is None]


needs_their_stack = pytest.mark.skipif(
    bool(missing_imports()),
    reason=f"the SASSI authors' code needs {', '.join(missing_imports())} (.ci/run installs "
    "them: torch==2.13.0 cupy-cuda12x scikit-learn cython, then fast-slic with "
    "--no-build-isolation)",
)


def run_theirs(root: Path, out: Path, vsize: int | None = None) -> dict[str, np.ndarray]:
    command = [sys.executable, str(HERE / "sassi_upstream_run.py"), str(root), "exp1", str(out)]
    if vsize is not None:
        command += ["--vsize", str(vsize)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=1200)
    assert done.returncode == 0, done.stderr[-3000:]
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


@pytest.fixture(scope="module")
def scored(sassi_root, sim_bundle, calibrated_sim, tmp_path_factory):
    """Their extraction and rank-1 with the exported window and with the former 3 rows,
    and this package's rank-1 of the same snapshot, against the truth."""
    from sassi_bench.procedure import load_procedure
    from sassi_bench.reduce.snapshots import reconstruct_snapshots

    root, done, video = sassi_root
    bundle, _ = sim_bundle
    procedure = load_procedure("snapshot_validation")
    reference = truth(calibrated_sim[0]).binned_cube(
        bundle.bin_edges, procedure["snapshot"]["light"], "natural"
    )
    mask = video.mask(0)
    valid = np.zeros(mask.shape, bool)
    valid[BORDER_PX:-BORDER_PX, BORDER_PX:-BORDER_PX] = True
    ours = next(reconstruct_snapshots(video, bundle, procedure, progress=False))
    folder = tmp_path_factory.mktemp("theirs")
    after = run_theirs(root, folder / "after.npz")
    before = run_theirs(root, folder / "before.npz", vsize=3)
    scores = {
        "vsize": done.vsize,
        "theirs_extraction": psnr_one_gain(after["cube"][mask], reference[mask]),
        "theirs_rank1": psnr_one_gain(after["cube_rec"][valid], reference[valid]),
        "theirs_extraction_vsize3": psnr_one_gain(before["cube"][mask], reference[mask]),
        "theirs_rank1_vsize3": psnr_one_gain(before["cube_rec"][valid], reference[valid]),
        "ours_extraction": psnr_one_gain(ours.spectra, reference[mask]),
        "ours_rank1": psnr_one_gain(ours.rank1[valid], reference[valid]),
        "ours_guided": psnr_one_gain(ours.guided[valid], reference[valid]),
    }
    print("PSNR (dB) against the truth:", {k: round(float(v), 2) for k, v in scores.items()})
    return scores, after, mask, reference, done


@needs_their_stack
def test_their_rank1_on_our_export_reaches_31_db(scored):
    """Their code as the README says, with the window the export chose by running their
    extraction on the frame: rank-1 >= 31 dB (measured 31.35 dB at vsize 9; their
    spectra at the open pixels 35.49 dB). With their former 3 rows it is 4.8 dB lower
    (measured 26.57 dB, spectra 26.48 dB): the exported window is what brings it up."""
    scores, *_ = scored
    assert scores["theirs_rank1"] >= 31.0, scores
    assert scores["theirs_rank1"] >= scores["theirs_rank1_vsize3"] + 3.0, scores
    assert scores["theirs_extraction"] >= scores["theirs_extraction_vsize3"] + 5.0, scores


@needs_their_stack
def test_our_extraction_leads_theirs(scored):
    """This package's spectra of the same frame beat theirs at the open pixels by >= 5 dB
    (measured 45.56 against 35.49 dB: their extraction has no row unmixing, no modelled
    background and no spectral deblur), and its guided filter beats their rank-1
    (measured 32.70 against 31.35 dB)."""
    scores, *_ = scored
    assert scores["ours_extraction"] >= scores["theirs_extraction"] + 5.0, scores
    assert scores["ours_guided"] >= scores["theirs_rank1"], scores


@needs_their_stack
def test_our_rank1_leads_theirs(scored):
    """On the same capture this package's rank-1 beats their rank-1 (measured 35.18
    against 31.36 dB on the planned mask's capture; 33.89 against 31.35 dB on one adaptive
    mask's, and 30.67 dB there while its regions reached one mean region side from their
    sample, where their slic_update reaches two: docs/notes/2026-11-29-snapshot-regions.md)."""
    scores, *_ = scored
    assert scores["ours_rank1"] >= scores["theirs_rank1"], scores


@needs_their_stack
def test_the_chosen_window_is_the_best_their_extraction_can_do(scored, sassi_root, sim_bundle):
    """The export scores every window against this package's spectra; scored against the
    truth instead, the window it chose is within 0.3 dB of the best (measured: the same
    window, 9). The package runs their functions composed as get_cassi_cube composes them:
    its cube for the chosen window is their get_cassi_cube's, exactly."""
    from scipy.io import loadmat

    from sassi_bench.export.sassi_mat import sassi_tables, suggested_ksizes

    _, after, mask, reference, done = scored
    root, _, _ = sassi_root
    bundle, _ = sim_bundle
    code = upstream_extraction()
    capture = loadmat(root / "exp1" / "adaptive_cassi.mat")
    tables = sassi_tables(bundle)
    ksizes = suggested_ksizes(bundle.blur_width(bundle.wavelengths))
    pattern = capture["lcos_mask"].astype(np.float32) / 255
    image = capture["cassi_img"].astype(np.float32)
    streaks = code.get_cassi_img(
        list(tables.xl.shape), pattern, tables.calibstack_row, tables.calibstack_col, ksizes
    )
    cleaned = image - code.get_offset(image, streaks)
    cleaned[cleaned < 0] = 0
    by_truth = {}
    for window in done.vsize_choice.candidates:
        cube = code._get_cassi_cube(cleaned, pattern, tables.yl, tables.xl, int(window), None)
        by_truth[int(window)] = psnr_one_gain(cube[mask], reference[mask])
        if window == done.vsize:
            np.testing.assert_array_equal(cube, after["cube"])
    assert max(by_truth.values()) - by_truth[done.vsize] <= 0.3, by_truth


def test_without_torch_the_choice_says_what_to_install(monkeypatch):
    from sassi_bench.errors import ProcedureError

    upstream_extraction.cache_clear()
    monkeypatch.setitem(sys.modules, "torch", None)
    try:
        with pytest.raises(ProcedureError, match=r"sassi-bench\[sassi\].*--vsize"):
            upstream_extraction()
    finally:
        upstream_extraction.cache_clear()
