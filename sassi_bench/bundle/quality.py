"""Quality checks recorded in a bundle's manifest (``quality.checks``).

A check is ``{name, value, tolerance, unit, passed}`` (plus ``comparison``, ``"<="`` or
``">="``, telling how value and tolerance were compared). A bundle passed when every check did.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from sassi_bench.bundle.errors import BundleError
from sassi_bench.bundle.jsonio import to_jsonable
from sassi_bench.errors import step_error

__all__ = ["QualityCheck", "format_tolerance", "normalize_quality", "unit_suffix"]


def unit_suffix(unit: str) -> str:
    """``" px"`` for a unit, ``""`` for a dimensionless value (unit ``"1"`` or empty).

    Examples
    --------
    >>> f"0.2{unit_suffix('px')}", f"0.97{unit_suffix('1')}"
    ('0.2 px', '0.97')
    """
    return "" if unit in ("1", "") else f" {unit}"


def format_tolerance(tolerance: float) -> str:
    """A tolerance at the precision it is set: three significant digits (one derived from a
    measurement, 5.06134, is 5.06; one set as 0.5 stays 0.5), no exponent below 1e6.

    Examples
    --------
    >>> [format_tolerance(t) for t in (5.06134, 0.5, 0.015, 30, 1000)]
    ['5.06', '0.5', '0.015', '30', '1000']
    """
    return f"{float(f'{tolerance:.3g}'):g}"


@dataclass(frozen=True)
class QualityCheck:
    """One acceptance test of a calibration.

    Parameters
    ----------
    name
        Short identifier, e.g. ``"dispersion_rms"``.
    value
        The measured value.
    tolerance
        The acceptance threshold.
    unit
        Unit of ``value`` and ``tolerance`` (``"px"``, ``"nm"``, ``"dB"``...).
    passed
        Whether the check passed.
    comparison
        ``"<="`` (value must not exceed the tolerance) or ``">="`` (must reach it).

    Examples
    --------
    >>> QualityCheck.at_most("dispersion_rms", 0.12, 0.5, "px").passed
    True
    >>> QualityCheck.at_least("psnr", 28.0, 30.0, "dB").passed
    False
    """

    name: str
    value: float
    tolerance: float
    unit: str
    passed: bool
    comparison: str = "<="

    @classmethod
    def at_most(cls, name: str, value: float, tolerance: float, unit: str) -> QualityCheck:
        """A check that passes when ``value <= tolerance``."""
        return cls(name, float(value), float(tolerance), unit, bool(value <= tolerance), "<=")

    @classmethod
    def at_least(cls, name: str, value: float, tolerance: float, unit: str) -> QualityCheck:
        """A check that passes when ``value >= tolerance``."""
        return cls(name, float(value), float(tolerance), unit, bool(value >= tolerance), ">=")

    def to_manifest(self) -> dict[str, Any]:
        """The manifest entry of this check."""
        return {
            "name": self.name,
            "value": self.value,
            "tolerance": self.tolerance,
            "unit": self.unit,
            "passed": self.passed,
            "comparison": self.comparison,
        }

    def describe(self) -> str:
        """``"dispersion_rms = 0.12 px (tolerance <= 0.5 px)"``.

        Examples
        --------
        >>> QualityCheck.at_least("valid_fraction", 0.97, 0.7, "1").describe()
        'valid_fraction = 0.97 (tolerance >= 0.7)'
        """
        unit = unit_suffix(self.unit)
        return (
            f"{self.name} = {self.value:.4g}{unit} "
            f"(tolerance {self.comparison} {format_tolerance(self.tolerance)}{unit})"
        )


def _check(item: Any, index: int) -> QualityCheck:
    if isinstance(item, QualityCheck):
        check = item
    elif isinstance(item, Mapping):
        missing = [k for k in ("name", "value", "tolerance", "unit", "passed") if k not in item]
        if missing:
            raise _bad(f"quality.checks[{index}] lacks {', '.join(missing)}")
        check = QualityCheck(
            name=item["name"],
            value=item["value"],
            tolerance=item["tolerance"],
            unit=item["unit"],
            passed=item["passed"],
            comparison=item.get("comparison", "<="),
        )
    else:
        raise _bad(f"quality.checks[{index}] is a {type(item).__name__}, not a QualityCheck")
    where = f"quality.checks[{index}] ({check.name!r})"
    if not isinstance(check.name, str) or not check.name:
        raise _bad(f"quality.checks[{index}].name must be a non-empty string")
    if not isinstance(check.unit, str):
        raise _bad(f"{where}.unit must be a string")
    if not isinstance(check.passed, bool):
        raise _bad(f"{where}.passed must be True or False")
    if check.comparison not in ("<=", ">="):
        raise _bad(f"{where}.comparison must be '<=' or '>='")
    for key in ("value", "tolerance"):
        number = getattr(check, key)
        if (
            isinstance(number, bool)
            or not isinstance(number, (int, float))
            or not math.isfinite(float(number))
        ):
            raise _bad(f"{where}.{key} must be a finite number, got {number!r}")
    holds = (
        check.value <= check.tolerance
        if check.comparison == "<="
        else check.value >= check.tolerance
    )
    if check.passed != holds:
        raise _bad(
            f"{where}.passed is {check.passed}, but {check.value:g} {check.comparison} "
            f"{format_tolerance(check.tolerance)} is {holds}"
        )
    return check


def _bad(cause: str) -> BundleError:
    return BundleError(
        step_error(
            "bundle publish",
            cause,
            "pass quality={'checks': [QualityCheck.at_most(name, value, tolerance, unit), ...]}",
        )
    )


def normalize_quality(quality: Mapping[str, Any]) -> tuple[dict[str, Any], list[QualityCheck]]:
    """Validate a ``quality`` section and convert it to plain JSON.

    Parameters
    ----------
    quality
        ``{"checks": [QualityCheck | mapping, ...], "residuals": {...},
        "leave_one_out": {...}, ...}``; keys other than ``checks`` are free JSON.

    Returns
    -------
    section, checks
        The JSON section for the manifest and the parsed checks.

    Examples
    --------
    >>> section, checks = normalize_quality({"checks": [QualityCheck.at_most("a", 1, 2, "px")]})
    >>> section["checks"][0]["passed"]
    True
    """
    if not isinstance(quality, Mapping) or "checks" not in quality:
        raise _bad("quality must be a mapping with a 'checks' list")
    items = quality["checks"]
    if isinstance(items, (str, bytes, Mapping)) or not isinstance(items, Iterable):
        raise _bad("quality['checks'] must be a list")
    checks = [_check(item, i) for i, item in enumerate(items)]
    names = [check.name for check in checks]
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise _bad(f"quality check names repeat: {', '.join(duplicates)}")
    section = to_jsonable({k: v for k, v in quality.items() if k != "checks"}, "quality")
    section["checks"] = to_jsonable([check.to_manifest() for check in checks], "quality.checks")
    return section, checks
