"""Reading the lab's YAML files (rig descriptions, procedures) with clear errors.

Every YAML file the workbench reads holds a mapping of keys at its top level. A missing
file, broken YAML or another top level (a list, an empty file) is refused with a
:class:`~sassi_bench.errors.ConfigError` that names the file, the cause and the fix.

Examples
--------
>>> import tempfile
>>> file = Path(tempfile.mkdtemp()) / "lab.yaml"
>>> _ = file.write_text("name: lab\\nlasers_nm: [450, 532]\\n")
>>> load_yaml_mapping(file, "procedure", missing_fix="check the path",
...                   mapping_fix="write the procedure as YAML keys")
{'name': 'lab', 'lasers_nm': [450, 532]}
"""

from __future__ import annotations

import os
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

import yaml

from sassi_bench.errors import ConfigError, step_error

__all__ = ["load_yaml_mapping"]


def load_yaml_mapping(
    file: str | os.PathLike[str] | Traversable,
    what: str,
    *,
    missing_fix: str,
    mapping_fix: str,
    label: str | None = None,
) -> dict[str, Any]:
    """Load a YAML file whose top level is a mapping.

    Parameters
    ----------
    file
        A path, or a file shipped in the package (``importlib.resources.files(...)``).
    what
        What the file describes, e.g. ``"rig description"``; every error's step is
        ``"<what> <label>"``.
    missing_fix
        The fix offered when the file does not exist.
    mapping_fix
        The fix offered when the top level is not a mapping.
    label
        How errors name the file; default: ``str(file)``. Shipped files are named by their
        place in the package (``"procedures/rigs/sim.yaml"``).

    Returns
    -------
    dict
        The parsed mapping, as :func:`yaml.safe_load` gives it.

    Raises
    ------
    ConfigError
        If the file does not exist, is not valid YAML, or its top level is not a mapping.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / "list.yaml").write_text("- 450\\n- 532\\n")
    >>> try:
    ...     load_yaml_mapping(folder / "list.yaml", "procedure", label="l.yaml",
    ...                       missing_fix="check the path", mapping_fix="use keys")
    ... except ConfigError as exc:
    ...     print(exc)
    procedure l.yaml: expected a mapping of keys at the top level, got list. Fix: use keys
    """
    if isinstance(file, (str, os.PathLike)):
        file = Path(file)
    where = f"{what} {label if label is not None else file}"
    if not file.is_file():
        raise ConfigError(step_error(where, "no such file", missing_fix))
    try:
        data = yaml.safe_load(file.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise ConfigError(
            step_error(
                where,
                f"not valid YAML ({' '.join(str(exc).split())})",
                "correct the YAML syntax at the line named",
            )
        ) from exc
    if not isinstance(data, dict):
        got = "an empty file" if data is None else type(data).__name__
        cause = f"expected a mapping of keys at the top level, got {got}"
        raise ConfigError(step_error(where, cause, mapping_fix))
    return data
