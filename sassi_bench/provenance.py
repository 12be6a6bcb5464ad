"""Which software made a result: the package version and, when known, the git commit.

A bundle records the commit of the code that published it. From a git checkout (an
editable install or a source tree) git is asked at run time. A regular install (``pip
install .``) has no ``.git``: the build writes ``sassi_bench/_build_info.json`` (version,
commit, uncommitted changes) into the wheel with :func:`write_build_info`, called by
``setup.py``, and it is read at run time instead. The file is generated, never committed.

This module uses the standard library only, so ``setup.py`` can load it by path before
any dependency is installed; it imports nothing slow until asked (``sassi-bench --help``
loads it).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

__all__ = [
    "BUILD_INFO_NAME",
    "git_state",
    "package_version",
    "read_build_info",
    "source_provenance",
    "write_build_info",
]

BUILD_INFO_NAME = "_build_info.json"
PACKAGE_DIR = Path(__file__).resolve().parent


def package_version() -> str:
    """The running package's version: the installed distribution's, else the one its build
    recorded, else ``"0+unknown"`` (a source tree that was never installed).

    Examples
    --------
    >>> isinstance(package_version(), str)
    True
    """
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("sassi-bench")
    except PackageNotFoundError:
        return (read_build_info() or {}).get("version") or "0+unknown"


def git_state(root: str | Path) -> tuple[str | None, bool | None]:
    """The commit checked out at ``root`` and whether tracked files differ from it.

    Returns ``(None, None)`` when ``root`` is not a git checkout with a commit (or git is
    not installed).

    Examples
    --------
    >>> git_state("/")
    (None, None)
    """
    import subprocess

    root = Path(root)
    if not (root / ".git").exists():  # a folder, or a file in a linked worktree
        return None, None

    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(
                ["git", "-C", str(root), *args],
                capture_output=True,
                text=True,
                timeout=5,
                check=False,
            )
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout if done.returncode == 0 else None

    commit = (git("rev-parse", "HEAD") or "").strip()
    if not re.fullmatch(r"[0-9a-f]{7,64}", commit):
        return None, None
    status = git("status", "--porcelain", "--untracked-files=no")
    return commit, None if status is None else bool(status.strip())


def write_build_info(package_dir: str | Path, *, version: str, source_root: str | Path) -> Path:
    """Write ``_build_info.json`` into a built package (the hook ``setup.py`` runs).

    Parameters
    ----------
    package_dir
        The ``sassi_bench`` folder inside the build directory.
    version
        The version being built.
    source_root
        The source tree the build runs from (asked for its git commit).

    Examples
    --------
    >>> import tempfile
    >>> path = write_build_info(tempfile.mkdtemp(), version="1.2.0", source_root="/")
    >>> json.loads(path.read_text())
    {'version': '1.2.0', 'git_commit': None, 'git_dirty': None}
    """
    commit, dirty = git_state(source_root)
    path = Path(package_dir) / BUILD_INFO_NAME
    info = {"version": version, "git_commit": commit, "git_dirty": dirty}
    path.write_text(json.dumps(info) + "\n", encoding="utf-8")
    return path


def read_build_info(package_dir: str | Path = PACKAGE_DIR) -> dict[str, Any] | None:
    """What the build recorded, or None (a source tree, or a file that is not readable).

    Examples
    --------
    >>> read_build_info("/nonexistent") is None
    True
    """
    try:
        info = json.loads((Path(package_dir) / BUILD_INFO_NAME).read_text("utf-8"))
    except (OSError, ValueError):
        return None
    return info if isinstance(info, dict) else None


def source_provenance(package_dir: str | Path = PACKAGE_DIR) -> dict[str, Any]:
    """``{"git_commit", "git_dirty", "from"}`` of the running package.

    ``from`` says where the commit came from: ``"git"`` (the package runs from a
    checkout), ``"build"`` (recorded when it was built) or None (unknown).

    Examples
    --------
    >>> sorted(source_provenance())
    ['from', 'git_commit', 'git_dirty']
    """
    commit, dirty = git_state(Path(package_dir).parent)
    if commit is not None:
        return {"git_commit": commit, "git_dirty": dirty, "from": "git"}
    built = read_build_info(package_dir)
    if built is not None and built.get("git_commit"):
        return {"git_commit": built["git_commit"], "git_dirty": built.get("git_dirty"),
                "from": "build"}  # fmt: skip
    return {"git_commit": None, "git_dirty": None, "from": None}
