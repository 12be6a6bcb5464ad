"""Every guided notebook runs top to bottom on the virtual bench, without a person.

The notebooks run in order in one data root (as a lab would: later notebooks use the
sessions and bundles of earlier ones), with their parameters cell replaced by small
settings, and each test checks what its notebook produced, not only that it ran. The
scan, Macbeth and snapshot notebooks take minutes each: ``tests/notebooks_browser`` runs
them, every cell, in JupyterLab, and checks the same.
"""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import numpy as np
import pytest

from sassi_bench.bundle import load, verify
from sassi_bench.rig import open_rig
from sassi_bench.rig.sim import truth

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


@pytest.fixture(scope="module")
def bench():
    """The sim rig's ground truth, to score what the notebooks publish."""
    return truth(open_rig("sim"))


def _field(bundle, step: int = 40):
    h, w = bundle.slm_shape
    v, u = np.mgrid[0:h:step, 0:w:step].reshape(2, -1).astype(float)
    return u, v


def wavelength_map_error_px(bundle, bench) -> float:
    """RMS camera distance between the bundle's and the true SLM -> camera map over the
    field at 450, 550 and 650 nm."""
    u, v = _field(bundle)
    errors = []
    for nm in (450.0, 550.0, 650.0):
        x, y = bundle.slm_to_camera(u, v, nm)
        tx, ty = bench.slm_to_camera(u, v, nm)
        errors.append((x - tx) ** 2 + (y - ty) ** 2)
    return float(np.sqrt(np.mean(errors)))


def homography_error_px(bundle, bench) -> float:
    """RMS SLM distance between the bundle's and the true guide -> SLM map over the field."""
    u, v = _field(bundle)
    slm = np.stack([u, v, np.ones_like(u)])
    guide = np.linalg.solve(bench.guide_to_slm, slm)
    mapped = bundle.guide_to_slm @ (guide / guide[2])
    return float(np.sqrt(np.mean(np.sum((mapped[:2] / mapped[2] - slm[:2]) ** 2, axis=0))))


nbclient = pytest.importorskip("nbclient", reason="nbclient comes with the notebooks extra")


@pytest.fixture(scope="module")
def lab(module_folder):
    """A data root shared by the notebooks of this module, in their numbered order."""
    return module_folder("notebook-lab")


def _run(name: str, data: Path, again: tuple[int, ...] = (), **extra) -> nbformat.NotebookNode:
    """Execute a notebook with small settings; then the cells ``again`` once more, in the
    same kernel, as a person does after changing a widget."""
    book = nbformat.read(NOTEBOOKS / name, as_version=4)
    cells = [c for c in book.cells if "parameters" in c.metadata.get("tags", [])]
    assert len(cells) == 1, f"{name} needs exactly one cell tagged 'parameters'"
    settings = {"rig_name": "sim", "session_id": "nb", "data": str(data), "progress": False}
    settings.update(extra)
    cells[0].source += "\n" + "\n".join(f"{k} = {v!r}" for k, v in settings.items())
    env = {**os.environ, "MPLBACKEND": "Agg"}
    # Run from the notebooks' folder, as JupyterLab does: nothing may be written there.
    client = nbclient.NotebookClient(
        book, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}
    )
    with client.setup_kernel(env=env):
        for index, cell in enumerate(book.cells):
            client.execute_cell(cell, index)
        for index in again:
            client.execute_cell(book.cells[index], index)
    assert _untracked_in_notebooks() == [], f"{name} wrote into the checkout"
    return book


def _untracked_in_notebooks() -> list[str]:
    """Files under notebooks/ that git does not know (nor ignore)."""
    import subprocess

    listed = subprocess.run(
        ["git", "ls-files", "--others", "--exclude-standard", "."],
        cwd=NOTEBOOKS, capture_output=True, text=True, check=False,
    )  # fmt: skip
    return listed.stdout.split() if listed.returncode == 0 else []


def _text(book, index: int | None = None) -> str:
    """The printed output of one cell, or of the whole notebook."""
    cells = book.cells if index is None else [book.cells[index]]
    return "".join(
        output.get("text", "")
        for cell in cells
        if cell.cell_type == "code"
        for output in cell.outputs
    )


def _images(book) -> int:
    return sum(
        "image/png" in output.get("data", {})
        for cell in book.cells
        if cell.cell_type == "code"
        for output in cell.outputs
    )


def test_notebooks_have_no_committed_outputs():
    for path in sorted(NOTEBOOKS.glob("*.ipynb")):
        book = nbformat.read(path, as_version=4)
        assert not any(c.get("outputs") for c in book.cells if c.cell_type == "code"), path.name


def test_00_quickstart_publishes_a_bundle_that_verifies(lab, bench):
    book = _run("00_quickstart.ipynb", lab, again=(8,))  # the publish cell run twice
    assert _images(book) >= 1  # the raw frames
    # The all-open frame is mostly saturated on the sim rig (63 %): the notebook says so.
    assert "\u26a0 spectral all open:" in _text(book, 4) and "Shorten the exposure" in _text(book, 4)
    live = book.cells[5].outputs  # the live view: a widget, shown, then stopped by itself
    assert any("application/vnd.jupyter.widget-view+json" in o.get("data", {}) for o in live)
    said = _text(book, 8)  # of its second run
    assert said.startswith("not published again: sim/v0001 already holds exactly these models")
    assert "latest: sim/v0001" in said and not (lab / "sim" / "v0002").exists()
    bundle_dir = lab / "sim" / "v0001"
    verify(bundle_dir)
    assert load(bundle_dir).wavelengths.size > 30
    assert wavelength_map_error_px(load(bundle_dir), bench) < 0.1


def test_01_laser_sweeps_captures_a_named_session(lab):
    book = _run("01_laser_sweeps.ipynb", lab)
    assert _images(book) >= 1
    assert (lab / "sessions" / "nb-sweep").is_dir()


def test_02_dispersion_and_blur_shows_the_fit(lab):
    book = _run("02_dispersion_and_blur.ipynb", lab)
    assert _images(book) >= 3  # residual maps, dispersion, blur
    assert not (lab / "sim" / "v0002").exists()  # this notebook only looks
    assert (lab / "procedures" / "nb-spectral_calibration.yaml").is_file()  # for 06


def test_04_guide_homography_publishes_the_homography(lab, bench):
    book = _run("04_guide_homography.ipynb", lab, again=(7,))
    assert _images(book) >= 2  # matches, checkerboard
    bundle = load(rig="sim", data=lab)
    assert bundle.guide_to_slm is not None
    assert homography_error_px(bundle, bench) < 0.3
    said = _text(book, 7)  # the publish cell, run a second time
    assert said.startswith(f"not published again: sim/{bundle.version} already holds exactly")
    assert f"latest: sim/{bundle.version} (dispersion, blur, guide homography" in said


def test_06_publish_bundle_does_not_publish_the_quick_starts_fit_again(lab, bench):
    # 01 and 02 settled the session 00 calibrated: the same fit, which v0001 holds.
    latest = (lab / "sim" / "LATEST").read_text().strip()
    before = {p.name for p in (lab / "sim").iterdir() if p.name.startswith("v")}
    book = _run("06_publish_bundle.ipynb", lab)
    after = {p.name for p in (lab / "sim").iterdir() if p.name.startswith("v")}
    assert after == before and (lab / "sim" / "LATEST").read_text().strip() == latest
    said = _text(book, 3)
    assert said.startswith("not published again: sim/v0001 already holds exactly these models")
    assert f"latest: sim/{latest} (dispersion, blur, guide homography" in said
    verify(lab / "sim" / "v0001")
    assert wavelength_map_error_px(load(lab / "sim" / "v0001"), bench) < 0.1


def test_08_health_check_holds_on_the_latest_bundle(lab):
    from sassi_bench.storage.health_history import HealthHistory, history_path

    book = _run("08_health_check.ipynb", lab)
    assert _images(book) >= 2  # the shift map and the trend
    (row,) = HealthHistory(history_path(lab)).rows(rig="sim")
    assert row["verdict"] == "holds" and row["shift_x_max_px"] < 0.1
