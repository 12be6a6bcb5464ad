"""Value checks of the model contract: every model value a bundle holds is checked by these.

Each check returns the value in its canonical form (a float, a tuple of floats, a read-only
float64 array, ...) or raises :class:`~sassi_bench.bundle.errors.BundleSchemaError` whose
message names the model key (``"models.blur.coeffs"``), the cause and the fix.

Examples
--------
>>> real(2, "models.blur.lambda_scale_nm", positive=True)
2.0
>>> real(-1.0, "models.blur.lambda_scale_nm", positive=True)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
sassi_bench.bundle.errors.BundleSchemaError: models.blur.lambda_scale_nm: must be > 0, got -1.0...
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.arrays import ShapePattern, check_dtype_kind, check_shape
from sassi_bench.bundle.errors import BundleSchemaError
from sassi_bench.errors import step_error

__all__ = [
    "array_ref",
    "bad",
    "frozen_array",
    "integer",
    "mapping",
    "real",
    "reals",
    "sequence",
]

_FIX = "the fitting code must produce models that follow sassi_bench.bundle.models"


def bad(where: str, cause: str, fix: str = _FIX) -> BundleSchemaError:
    """The error for a model value at ``where`` that breaks the contract."""
    return BundleSchemaError(step_error(where, cause, fix))


def real(value: Any, where: str, *, positive: bool = False) -> float:
    """A finite real number (``> 0`` if ``positive``) as a float."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise bad(where, f"must be a number, got {type(value).__name__}")
    try:
        out = float(value)
    except OverflowError:
        out = math.inf
    if not math.isfinite(out):
        raise bad(where, f"must be finite, got {out}")
    if positive and out <= 0:
        raise bad(where, f"must be > 0, got {out}")
    return out


def reals(value: Any, count: int, where: str) -> tuple[float, ...]:
    """``count`` finite real numbers as a tuple of floats."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
        raise bad(where, f"must be a list of {count} numbers")
    items = list(value)
    if len(items) != count:
        raise bad(where, f"must hold {count} numbers, got {len(items)}")
    return tuple(real(item, f"{where}[{i}]") for i, item in enumerate(items))


def integer(value: Any, where: str, low: int, high: int) -> int:
    """An integer between ``low`` and ``high`` (inclusive)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise bad(where, f"must be an integer, got {type(value).__name__}")
    if not low <= int(value) <= high:
        raise bad(where, f"must be between {low} and {high}, got {value}")
    return int(value)


def sequence(value: Any, count: int, where: str) -> list[Any]:
    """``count`` values of any kind, as a list."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
        raise bad(where, f"must be a list of {count} values")
    items = list(value)
    if len(items) != count:
        raise bad(where, f"must hold {count} values, got {len(items)}")
    return items


def frozen_array(
    value: Any,
    where: str,
    shape: ShapePattern,
    *,
    expected_for: str | None = None,
    allow_empty: bool = True,
) -> NDArray[np.float64]:
    """Read-only float64 copy of a finite real array of ``shape``.

    ``shape``, ``expected_for`` and ``allow_empty`` are those of
    :func:`~sassi_bench._shared.arrays.check_shape` (``("K", 6)``: any K rows of 6).

    Examples
    --------
    >>> frozen_array([[1, 2]], "models.blur.coeffs", ("K", 2)).dtype
    dtype('float64')
    >>> frozen_array([1, 2], "models.response", (3,), expected_for="3 bins")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.bundle.errors.BundleSchemaError: models.response: the value has shape (2,), ...
    """
    try:
        array = np.asarray(value)
    except (ValueError, TypeError, OverflowError) as exc:
        raise bad(where, f"is not a numeric array ({exc})") from exc
    check_dtype_kind(array, "iuf", step=where, name="the value", fix=_FIX, error=BundleSchemaError)
    check_shape(
        array,
        shape,
        step=where,
        name="the value",
        expected_for=expected_for,
        fix=_FIX,
        allow_empty=allow_empty,
        error=BundleSchemaError,
    )
    out = np.array(array, dtype=np.float64, copy=True)
    if not np.all(np.isfinite(out)):
        raise bad(where, "holds NaN or infinite values")
    out.flags.writeable = False
    return out


def array_ref(entry: Mapping[str, Any], key: str, arrays: Mapping[str, Any], where: str) -> Any:
    """The array that ``entry[key]`` names, from the bundle's ``arrays``."""
    name = entry.get(key)
    if not isinstance(name, str):
        raise bad(f"{where}.{key}", "must name an array")
    if name not in arrays:
        raise bad(
            f"{where}.{key}",
            f"names array {name!r}, which the bundle does not hold",
            "publish the bundle again; every array a model names must be saved with it",
        )
    return arrays[name]


def mapping(value: Any, where: str) -> Mapping[str, Any]:
    """A JSON object (any mapping)."""
    if not isinstance(value, Mapping):
        raise bad(where, f"must be an object, got {type(value).__name__}")
    return value
