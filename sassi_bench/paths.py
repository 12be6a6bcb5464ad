"""Where the workbench keeps its data.

Bundles, raw sessions, staging folders and reports live under one data root, resolved
the same way from any folder, first match wins:

1. an explicit directory: the ``--data DIR`` option of every command, or ``data=`` of
   the Python functions;
2. the ``SASSI_BENCH_DATA`` environment variable;
3. ``calib_data/`` of the nearest enclosing sassi_bench checkout: the first folder,
   walking up from the current directory, that holds ``pyproject.toml`` and
   ``sassi_bench/__init__.py`` (so a notebook run from ``notebooks/``, whose working
   directory is that folder, uses the repository's ``calib_data/``);
4. ``calib_data/`` in the current directory.

Scripts and tests pass a temporary directory so they never touch the repository's own
``calib_data/``.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["DATA_ENV_VAR", "checkout_root", "data_root", "shared_mode"]

DATA_ENV_VAR = "SASSI_BENCH_DATA"


DATA_DIR_NAME = "calib_data"


def checkout_root(start: str | os.PathLike[str] | None = None) -> Path | None:
    """The nearest folder at or above ``start`` (default: the current directory) that is
    a sassi_bench checkout (holds ``pyproject.toml`` and ``sassi_bench/__init__.py``).

    Examples
    --------
    >>> checkout_root("/") is None
    True
    """
    here = Path.cwd() if start is None else Path(start)
    for folder in (here, *here.parents):
        if (folder / "pyproject.toml").is_file() and (
            folder / "sassi_bench" / "__init__.py"
        ).is_file():
            return folder
    return None


def data_root(explicit: str | os.PathLike[str] | None = None) -> Path:
    """Resolve the data root (see the module docstring for the rule).

    Parameters
    ----------
    explicit
        A directory given on the command line or by the caller; wins when not None.

    Returns
    -------
    pathlib.Path
        The directory (not created here).

    Examples
    --------
    >>> data_root("/tmp/lab").as_posix()
    '/tmp/lab'
    """
    if explicit is not None:
        root = Path(explicit)
    elif os.environ.get(DATA_ENV_VAR):
        root = Path(os.environ[DATA_ENV_VAR])
    elif (checkout := checkout_root()) is not None:
        root = checkout / DATA_DIR_NAME
    else:
        root = Path(DATA_DIR_NAME)
    if root.exists() and not root.is_dir():
        from sassi_bench.errors import ConfigError, step_error

        raise ConfigError(
            step_error("data root", f"{root} is a file, not a folder", "give a folder")
        )
    return root


def shared_mode(directory: bool) -> int:
    """Permission bits a new file or folder would get from the process umask.

    ``tempfile.mkstemp``/``mkdtemp`` create private (0600/0700) entries; the workbench's
    bundles and sessions are shared lab records, so they get the umask's usual mode.

    Examples
    --------
    >>> oct(shared_mode(directory=True) & 0o700)
    '0o700'
    """
    mask = os.umask(0)
    os.umask(mask)
    return (0o777 if directory else 0o666) & ~mask
