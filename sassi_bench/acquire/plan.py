"""Capture plans: the ordered list of frames a procedure needs, as plain data.

A :class:`Plan` is a named tuple of :class:`Step` objects plus free procedure
parameters. Each step says which camera captures under which light, with which
exposure, while the SLM shows which pattern (a descriptor for
:func:`~sassi_bench.acquire.patterns.render_pattern`), and carries free ``tags`` that
analysis code uses to find its frames again (``plan.select(role="gray", bit=3)``).

Plans hold JSON only: they round-trip through :meth:`Plan.to_dict` /
:meth:`Plan.from_dict` exactly, and :meth:`Plan.sha256` identifies one in session
files and bundle inputs. Steps are immutable (mappings become read-only views).

Examples
--------
>>> step = Step("spectral", "laser:532", 0.01, {"kind": "pinholes", "pitch": [100, 50]})
>>> plan = Plan("pinholes-532", (step,), {"laser": 532})
>>> Plan.from_dict(plan.to_dict()) == plan
True
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from sassi_bench._shared.canonical_json import canonical_json, canonical_sha256
from sassi_bench.errors import ConfigError, step_error

__all__ = [
    "CAMERAS",
    "Plan",
    "PlanError",
    "Step",
    "to_json_value",
]

CAMERAS = ("spectral", "guide")
"""Camera names a step may use: the rig's ``spectral_camera`` and ``guide_camera``."""

_EMPTY: Mapping[str, Any] = MappingProxyType({})
_STEP_KEYS = ("camera", "light", "exposure_s", "pattern", "tags")
_PLAN_KEYS = ("name", "steps", "parameters")


class PlanError(ConfigError):
    """A capture plan (or a step of one) is invalid; the message names the key."""


def _refuse(where: str, cause: str, fix: str) -> PlanError:
    return PlanError(step_error("capture plan", f"{where} {cause}", fix))


def to_json_value(value: Any, where: str = "value") -> Any:
    """Convert ``value`` to plain JSON types, refusing what JSON cannot hold.

    numpy scalars and arrays become Python numbers and lists, tuples become lists,
    mappings become dicts (string keys only). Non-finite floats are refused so the
    canonical form, and thus every hash, is well defined.

    Parameters
    ----------
    value
        The object to convert.
    where
        Dotted name of ``value`` for error messages, e.g. ``"steps[3].tags"``.

    Returns
    -------
    Any
        A new object made of dict, list, str, int, float, bool and None.

    Raises
    ------
    PlanError
        Naming ``where`` and the offending part.

    Examples
    --------
    >>> to_json_value({"pitch": (np.int64(100), 5), "on": np.bool_(True)})
    {'pitch': [100, 5], 'on': True}
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.generic):
        return to_json_value(value.item(), where)
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise _refuse(where, f"is {value!r}", "use finite numbers (None for a missing value)")
        return float(value)
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            raise _refuse(where, f"is an array of dtype {value.dtype}", "pass numbers")
        return to_json_value(value.tolist(), where)
    if isinstance(value, Mapping):
        out: dict[str, Any] = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise _refuse(f"{where}[{key!r}]", "has a non-string key", "use string keys")
            out[key] = to_json_value(item, f"{where}.{key}")
        return out
    if isinstance(value, Sequence) and not isinstance(value, (bytes, bytearray)):
        return [to_json_value(item, f"{where}[{i}]") for i, item in enumerate(value)]
    raise _refuse(
        where,
        f"has type {type(value).__name__}, which JSON cannot hold",
        "use dict, list, str, int, float, bool or None",
    )


def _freeze(value: Any) -> Any:
    if isinstance(value, dict):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, list):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_thaw(v) for v in value]
    return value


def _check_keys(data: Any, allowed: tuple[str, ...], required: tuple[str, ...], where: str):
    if not isinstance(data, Mapping):
        raise _refuse(where, f"is a {type(data).__name__}, not a mapping", "pass a dict")
    for key in data:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f"did you mean {close[0]!r}?" if close else f"use only {', '.join(allowed)}"
            raise _refuse(f"{where}.{key}", "is not a known key", hint)
    for key in required:
        if key not in data:
            raise _refuse(f"{where}.{key}", "is missing", f"add {key!r}")


def _same(a: Any, b: Any) -> bool:
    # JSON equality where True is not 1 (a tag ``inverse: False`` must not match ``bit: 0``).
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


@dataclass(frozen=True)
class Step:
    """One frame of a plan.

    Parameters
    ----------
    camera
        ``"spectral"`` or ``"guide"``.
    light
        Light to select, e.g. ``"laser:532"``, ``"led"``, ``"off"``.
    exposure_s
        Exposure of ``camera``, seconds (> 0).
    pattern
        SLM pattern descriptor for :func:`~sassi_bench.acquire.patterns.render_pattern`
        (JSON; must have a ``"kind"``).
    tags
        Free JSON labels that analysis code selects frames by, e.g.
        ``{"role": "gray", "axis": "x", "bit": 3, "inverse": False}``.

    Examples
    --------
    >>> s = Step("guide", "led", 0.02, {"kind": "blank"}, {"role": "guide"})
    >>> s.tags["role"], s.to_dict()["pattern"]
    ('guide', {'kind': 'blank'})
    """

    camera: str
    light: str
    exposure_s: float
    pattern: Mapping[str, Any]
    tags: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._validate("step")

    def _validate(self, where: str) -> None:
        if self.camera not in CAMERAS:
            raise _refuse(f"{where}.camera", f"is {self.camera!r}", f"use one of {CAMERAS}")
        if not isinstance(self.light, str) or not self.light.strip():
            raise _refuse(
                f"{where}.light", f"is {self.light!r}", "name a light, e.g. 'laser:532' or 'led'"
            )
        exposure = self.exposure_s
        if (
            isinstance(exposure, bool)
            or not isinstance(exposure, (int, float, np.integer, np.floating))
            or not math.isfinite(exposure)
            or exposure <= 0
        ):
            raise _refuse(
                f"{where}.exposure_s", f"is {exposure!r}", "use a positive number of seconds"
            )
        pattern = to_json_value(self.pattern, f"{where}.pattern")
        if not isinstance(pattern, dict) or not isinstance(pattern.get("kind"), str):
            raise _refuse(
                f"{where}.pattern",
                f"is {pattern!r}, a descriptor needs a string 'kind'",
                "pass e.g. {'kind': 'pinholes', 'pitch': [100, 5]}",
            )
        tags = to_json_value(self.tags, f"{where}.tags")
        if not isinstance(tags, dict):
            raise _refuse(f"{where}.tags", f"is {tags!r}", "pass a dict of labels")
        object.__setattr__(self, "exposure_s", float(exposure))
        object.__setattr__(self, "pattern", _freeze(pattern))
        object.__setattr__(self, "tags", _freeze(tags))

    def __hash__(self) -> int:
        return hash(canonical_json(self.to_dict()))

    def matches(self, **tags: Any) -> bool:
        """Whether every given tag is present with an equal (JSON) value.

        Examples
        --------
        >>> Step("spectral", "led", 1.0, {"kind": "full"}, {"bit": 0}).matches(bit=0)
        True
        """
        wanted = to_json_value(tags, "select")
        return all(key in self.tags and _same(self.tags[key], v) for key, v in wanted.items())

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON form (a new dict).

        Examples
        --------
        >>> Step("spectral", "off", 1, {"kind": "blank"}).to_dict()["exposure_s"]
        1.0
        """
        return {
            "camera": self.camera,
            "light": self.light,
            "exposure_s": self.exposure_s,
            "pattern": _thaw(self.pattern),
            "tags": _thaw(self.tags),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "step") -> Step:
        """Build a step from :meth:`to_dict` output, naming ``where`` in errors.

        Examples
        --------
        >>> Step.from_dict({"camera": "guide", "light": "led", "exposure_s": 0.1,
        ...                 "pattern": {"kind": "blank"}}).camera
        'guide'
        """
        _check_keys(data, _STEP_KEYS, _STEP_KEYS[:4], where)
        step = object.__new__(cls)
        for key in _STEP_KEYS:
            object.__setattr__(step, key, data.get(key, _EMPTY))
        step._validate(where)
        return step


@dataclass(frozen=True)
class Plan:
    """A named, ordered tuple of steps plus free procedure parameters.

    Parameters
    ----------
    name
        Short name, used in default session ids and progress bars.
    steps
        The frames to capture, in order (at least one).
    parameters
        Free JSON recording how the plan was built (laser list, pitch, ...). The key
        ``"scene"``, when present, is the scene :func:`~sassi_bench.acquire.runner.run_plan`
        puts in front of the bench before capturing (at ``"scene_pose"`` if given).

    Examples
    --------
    >>> steps = [Step("spectral", "laser:532", 0.01, {"kind": "gray", "axis": "x",
    ...          "bit": b, "block": 8, "inverse": False}, {"role": "gray", "bit": b})
    ...          for b in range(3)]
    >>> plan = Plan("gray-532", steps)
    >>> len(plan), plan.select(bit=1), len(plan.sha256())
    (3, [1], 64)
    """

    name: str
    steps: tuple[Step, ...]
    parameters: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise _refuse("name", f"is {self.name!r}", "give the plan a short non-empty name")
        steps = tuple(self.steps)
        if not steps:
            raise _refuse("steps", "is empty", "add at least one Step")
        for i, step in enumerate(steps):
            if not isinstance(step, Step):
                raise _refuse(f"steps[{i}]", f"is a {type(step).__name__}", "pass Step objects")
        parameters = to_json_value(self.parameters, "parameters")
        if not isinstance(parameters, dict):
            raise _refuse("parameters", f"is {parameters!r}", "pass a dict")
        object.__setattr__(self, "steps", steps)
        object.__setattr__(self, "parameters", _freeze(parameters))

    def __len__(self) -> int:
        return len(self.steps)

    def __iter__(self) -> Iterator[Step]:
        return iter(self.steps)

    def __hash__(self) -> int:
        return hash(self.sha256())

    @property
    def cameras(self) -> tuple[str, ...]:
        """Cameras the plan uses, in order of first use.

        Examples
        --------
        >>> Plan("p", [Step("guide", "led", 1, {"kind": "blank"})]).cameras
        ('guide',)
        """
        return tuple(dict.fromkeys(step.camera for step in self.steps))

    def select(self, **tags: Any) -> list[int]:
        """Indices of the steps whose tags match every given key and value.

        A step lacking a key does not match; ``True`` does not match ``1``.

        Examples
        --------
        >>> s = lambda **t: Step("spectral", "led", 1, {"kind": "full"}, t)
        >>> Plan("p", [s(role="dark"), s(role="gray", bit=0), s(role="gray", bit=1)]).select(
        ...     role="gray")
        [1, 2]
        """
        return [i for i, step in enumerate(self.steps) if step.matches(**tags)]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON form: ``{"name", "parameters", "steps": [step dicts]}``.

        Examples
        --------
        >>> sorted(Plan("p", [Step("guide", "led", 1, {"kind": "blank"})]).to_dict())
        ['name', 'parameters', 'steps']
        """
        return {
            "name": self.name,
            "parameters": _thaw(self.parameters),
            "steps": [step.to_dict() for step in self.steps],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Plan:
        """Build a plan from :meth:`to_dict` output (e.g. parsed JSON), validating it.

        Raises
        ------
        PlanError
            Naming the offending key (``steps[3].exposure_s``) and the fix.

        Examples
        --------
        >>> Plan.from_dict({"name": "p", "steps": [{"camera": "guide", "light": "led",
        ...     "exposure_s": 1, "pattern": {"kind": "blank"}}]}).steps[0].light
        'led'
        """
        _check_keys(data, _PLAN_KEYS, ("name", "steps"), "plan")
        raw_steps = data["steps"]
        if not isinstance(raw_steps, Sequence) or isinstance(raw_steps, (str, bytes)):
            raise _refuse("plan.steps", f"is a {type(raw_steps).__name__}", "pass a list")
        steps = tuple(Step.from_dict(s, f"plan.steps[{i}]") for i, s in enumerate(raw_steps))
        return cls(data["name"], steps, data.get("parameters", _EMPTY))

    def sha256(self) -> str:
        """SHA-256 (hex) of the canonical JSON of :meth:`to_dict`.

        Examples
        --------
        >>> p = Plan("p", [Step("guide", "led", 1, {"kind": "blank"})])
        >>> p.sha256() == Plan.from_dict(p.to_dict()).sha256()
        True
        """
        return canonical_sha256(self.to_dict())

    @classmethod
    def concat(cls, *plans: Plan, name: str, parameters: Mapping[str, Any] | None = None) -> Plan:
        """Join plans end to end into one.

        Parameters
        ----------
        *plans
            The plans, in capture order.
        name
            Name of the joined plan.
        parameters
            Parameters of the joined plan. By default ``{"parts": [...]}`` records each
            part's name, parameters and step range ``[start, stop)``.

        Examples
        --------
        >>> a = Plan("a", [Step("guide", "led", 1, {"kind": "blank"})])
        >>> b = Plan("b", [Step("spectral", "led", 1, {"kind": "full"})] * 2)
        >>> ab = Plan.concat(a, b, name="ab")
        >>> len(ab), ab.parameters["parts"][1]["start"]
        (3, 1)
        """
        if not plans:
            raise _refuse("concat", "got no plans", "pass at least one Plan")
        parts, steps = [], []
        for plan in plans:
            if not isinstance(plan, Plan):
                raise _refuse("concat", f"got a {type(plan).__name__}", "pass Plan objects")
            parts.append(
                {
                    "name": plan.name,
                    "parameters": _thaw(plan.parameters),
                    "start": len(steps),
                    "stop": len(steps) + len(plan),
                }
            )
            steps.extend(plan.steps)
        return cls(name, tuple(steps), {"parts": parts} if parameters is None else parameters)
