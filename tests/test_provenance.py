"""A bundle names the commit of its software, from a checkout or an installed wheel."""

import json
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from sassi_bench.provenance import (
    BUILD_INFO_NAME,
    git_state,
    read_build_info,
    source_provenance,
    write_build_info,
)

ROOT = Path(__file__).resolve().parents[1]
# The one failure that is the machine's, not the build's: pip cannot fetch the build
# backend the isolated build needs (no network, no index holding it).
_NO_BUILD_BACKEND = re.compile(
    r"(No matching distribution found|Could not find a version that satisfies the "
    r"requirement) (for )?(setuptools|wheel)\b"
)


def _git(repo: Path, *args: str) -> str:
    done = subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True,
                          check=True)  # fmt: skip
    return done.stdout.strip()


@pytest.fixture
def checkout(tmp_path: Path) -> Path:
    """A git checkout holding a sassi_bench package folder, with one commit."""
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    repo = tmp_path / "src"
    (repo / "sassi_bench").mkdir(parents=True)
    (repo / "sassi_bench" / "__init__.py").write_text("")
    _git(repo, "init", "-q")
    _git(repo, "add", ".")
    _git(repo, "-c", "user.name=t", "-c", "user.email=t@example.org", "commit", "-qm", "init")
    return repo


def test_the_build_hook_records_the_checkouts_commit(checkout, tmp_path):
    built = tmp_path / "build" / "sassi_bench"
    built.mkdir(parents=True)
    write_build_info(built, version="0.1.0", source_root=checkout)
    head = _git(checkout, "rev-parse", "HEAD")
    assert read_build_info(built) == {"version": "0.1.0", "git_commit": head, "git_dirty": False}
    (checkout / "sassi_bench" / "__init__.py").write_text("x = 1\n")
    write_build_info(built, version="0.1.0", source_root=checkout)
    assert read_build_info(built)["git_dirty"] is True


def test_an_installed_copy_reads_what_its_build_recorded(checkout, tmp_path):
    installed = tmp_path / "site-packages" / "sassi_bench"
    installed.mkdir(parents=True)
    write_build_info(installed, version="0.1.0", source_root=checkout)
    head = _git(checkout, "rev-parse", "HEAD")
    assert source_provenance(installed) == {"git_commit": head, "git_dirty": False,
                                            "from": "build"}  # fmt: skip
    # From the checkout itself (an editable install) git is asked at run time.
    assert source_provenance(checkout / "sassi_bench")["from"] == "git"
    assert git_state(checkout) == (head, False)
    (installed / BUILD_INFO_NAME).unlink()
    assert source_provenance(installed) == {"git_commit": None, "git_dirty": None, "from": None}


def test_a_wheel_built_from_the_checkout_records_its_commit(tmp_path):
    """The real build (pip wheel, isolated), as `pip install .` runs it."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(
        ".venv", "build", "*.egg-info", "__pycache__", "calib_data", ".pytest_cache"))  # fmt: skip
    done = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "-q",
         "-w", str(tmp_path / "dist")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    if done.returncode != 0 and _NO_BUILD_BACKEND.search(done.stderr):
        # pip builds in isolation: it fetches the build backend (setuptools, wheel) first.
        pytest.skip(f"no build backend to fetch here (offline?): {done.stderr[-300:]}")
    assert done.returncode == 0, done.stderr[-2000:]
    (wheel,) = (tmp_path / "dist").glob("*.whl")
    with zipfile.ZipFile(wheel) as archive:
        info = json.loads(archive.read(f"sassi_bench/{BUILD_INFO_NAME}"))
    assert info["git_commit"] == _git(ROOT, "rev-parse", "HEAD")
    assert info["version"] == "0.1.0"
