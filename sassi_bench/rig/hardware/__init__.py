"""Adapters for a real bench: serial trigger, SLM display window, GenICam and DCAM cameras.

Each adapter implements a protocol of :mod:`sassi_bench.rig.protocols` through the
checked bases of :mod:`sassi_bench.rig.base`. Vendor SDKs are optional and imported
only when an adapter is built; a missing one raises a
:class:`~sassi_bench.errors.DeviceError` naming what to install.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from sassi_bench.errors import DeviceError, step_error

__all__ = ["require"]


def require(module: str, package: str, step: str) -> ModuleType:
    """Import an optional dependency or explain how to install it.

    Parameters
    ----------
    module
        Module to import (``"harvesters.core"``).
    package
        The distribution that provides it (``"harvesters"``).
    step
        What needed it, for the error message.

    Raises
    ------
    DeviceError
        When the import fails, naming the package and the ``hardware`` extra.

    Examples
    --------
    >>> require("json", "json", "demo").__name__
    'json'
    >>> require("no_such_sdk", "no-such-sdk", "camera open")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.DeviceError: camera open: the Python package 'no-such-sdk' is not ...
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise DeviceError(
            step_error(
                step,
                f"the Python package {package!r} is not installed ({exc})",
                f"pip install 'sassi-bench[hardware]' (or pip install {package})",
            )
        ) from exc
