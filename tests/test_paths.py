"""The data root resolves to the same folder from anywhere inside a checkout."""

from pathlib import Path

import pytest

from sassi_bench.paths import DATA_ENV_VAR, checkout_root, data_root


@pytest.fixture
def checkout(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder shaped like a sassi_bench checkout, with a notebooks/ folder."""
    monkeypatch.delenv(DATA_ENV_VAR, raising=False)
    root = tmp_path / "repo"
    (root / "sassi_bench").mkdir(parents=True)
    (root / "sassi_bench" / "__init__.py").write_text("")
    (root / "pyproject.toml").write_text('[project]\nname = "sassi-bench"\n')
    (root / "notebooks" / "deep").mkdir(parents=True)
    return root


def test_a_notebook_folder_uses_the_checkouts_data_root(checkout, monkeypatch):
    for folder in (checkout, checkout / "notebooks", checkout / "notebooks" / "deep"):
        monkeypatch.chdir(folder)
        assert data_root() == checkout / "calib_data"
        assert checkout_root() == checkout


def test_explicit_and_environment_win_and_elsewhere_is_the_current_folder(
    checkout, tmp_path, monkeypatch
):
    monkeypatch.chdir(checkout / "notebooks")
    monkeypatch.setenv(DATA_ENV_VAR, str(tmp_path / "lab"))
    assert data_root() == tmp_path / "lab"
    assert data_root(tmp_path / "mine") == tmp_path / "mine"
    monkeypatch.delenv(DATA_ENV_VAR)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    monkeypatch.chdir(outside)
    assert checkout_root() is None and data_root() == Path("calib_data")


def test_data_folders_are_ignored_by_git():
    ignored = (Path(__file__).parents[1] / ".gitignore").read_text().splitlines()
    for pattern in ("calib_data/sessions/", "calib_data/staging/", "calib_data/reports/",
                    "notebooks/calib_data/"):  # fmt: skip
        assert pattern in ignored
