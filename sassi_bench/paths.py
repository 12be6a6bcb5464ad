"""Where the workbench keeps its data.

Bundles and raw sessions live under one data root: ``calib_data/`` in the current
directory by default, the ``SASSI_BENCH_DATA`` environment variable when set, or the
``--data DIR`` option of every command (which wins over both). Scripts and tests pass a
temporary directory so they never touch the repository's own ``calib_data/``.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["DATA_ENV_VAR", "data_root", "shared_mode"]

DATA_ENV_VAR = "SASSI_BENCH_DATA"


def data_root(explicit: str | os.PathLike[str] | None = None) -> Path:
    """Resolve the data root.

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
    else:
        root = Path("calib_data")
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
