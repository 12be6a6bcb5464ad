"""Capture plans: validation, JSON round trip, stable hashes, tag selection, concatenation."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench.acquire.plan import Plan, PlanError, Step
from sassi_bench.errors import ConfigError


def golden_plan() -> Plan:
    return Plan(
        "golden",
        (
            Step(
                "spectral",
                "laser:532",
                0.01,
                {"kind": "pinholes", "pitch": [100, 50]},
                {"role": "pinholes", "laser": 532},
            ),
            Step("guide", "led", 0.02, {"kind": "blank"}),
        ),
        {"laser": 532},
    )


def gray_plan() -> Plan:
    steps = []
    for axis in ("x", "y"):
        for bit in range(3):
            for inverse in (False, True):
                pattern = {"kind": "gray", "axis": axis, "bit": bit, "block": 8, "inverse": inverse}
                tags = {"role": "gray", "axis": axis, "bit": bit, "inverse": inverse}
                steps.append(Step("spectral", "laser:532", 0.01, pattern, tags))
    steps.append(Step("spectral", "off", 0.01, {"kind": "blank"}, {"role": "dark"}))
    return Plan("gray-532", steps, {"block": 8, "lasers": [532]})


def test_json_round_trip_is_exact():
    plan = gray_plan()
    text = json.dumps(plan.to_dict())
    back = Plan.from_dict(json.loads(text))
    assert back == plan
    assert back.to_dict() == plan.to_dict()
    assert back.sha256() == plan.sha256()


def test_sha256_is_the_hash_of_the_canonical_json_and_is_stable():
    plan = golden_plan()
    canonical = canonical_json(plan.to_dict())
    assert plan.sha256() == hashlib.sha256(canonical).hexdigest()
    # A change of the canonical form would silently change every session's identity.
    assert plan.sha256() == "601fcf331bb377ead9bca08b51b9888f63241beccdb3d138f2f40e8fab3d5c2e"


def test_sha256_ignores_key_order_and_numpy_types_but_not_values():
    a = Step("spectral", "led", 0.5, {"kind": "lines", "axis": "x", "offset": 0, "spacing": 4})
    b = Step(
        "spectral",
        "led",
        np.float64(0.5),
        {"spacing": np.int64(4), "offset": 0, "axis": "x", "kind": "lines"},
    )
    assert Plan("p", [a]).sha256() == Plan("p", [b]).sha256()
    c = Step("spectral", "led", 0.25, dict(a.pattern))
    assert Plan("p", [a]).sha256() != Plan("p", [c]).sha256()
    assert Plan("p", [a]).sha256() != Plan("q", [a]).sha256()


def test_select_matches_all_given_tags():
    plan = gray_plan()
    gray = plan.select(role="gray")
    assert len(gray) == 12
    assert plan.select(role="gray", axis="y", bit=2, inverse=True) == [11]
    assert plan.select(role="dark") == [12]
    assert plan.select(role="gray", axis="z") == []
    assert plan.select() == list(range(len(plan)))


def test_select_needs_the_key_and_does_not_confuse_bools_with_ints():
    plan = gray_plan()
    assert plan.select(bit=0, inverse=False) == [0, 6]
    assert plan.select(inverse=0) == []  # 0 is not False
    assert plan.select(missing_key=1) == []


def test_select_compares_lists_and_tuples_as_json():
    step = Step("spectral", "led", 1, {"kind": "full"}, {"pitch": [100, 5]})
    assert Plan("p", [step]).select(pitch=(100, 5)) == [0]
    assert Plan("p", [step]).select(pitch=[100, 6]) == []


def test_steps_are_immutable_and_dicts_are_copies():
    step = Step("spectral", "led", 1, {"kind": "pinholes", "pitch": [100, 5]}, {"a": {"b": 1}})
    with pytest.raises(TypeError):
        step.tags["c"] = 2  # type: ignore[index]
    with pytest.raises(TypeError):
        step.tags["a"]["b"] = 2  # type: ignore[index]
    out = step.to_dict()
    out["pattern"]["pitch"].append(7)
    assert step.pattern["pitch"] == (100, 5)
    assert hash(step) == hash(Step.from_dict(step.to_dict()))


def test_caller_dicts_are_copied_in():
    pattern = {"kind": "pinholes", "pitch": [100, 5]}
    step = Step("spectral", "led", 1, pattern)
    pattern["pitch"][0] = 3
    assert step.pattern["pitch"] == (100, 5)


@pytest.mark.parametrize(
    ("kwargs", "where"),
    [
        ({"camera": "ir"}, "step.camera"),
        ({"light": ""}, "step.light"),
        ({"exposure_s": 0}, "step.exposure_s"),
        ({"exposure_s": float("nan")}, "step.exposure_s"),
        ({"exposure_s": True}, "step.exposure_s"),
        ({"pattern": {"pitch": [1, 2]}}, "step.pattern"),
        ({"tags": {"when": object()}}, "step.tags.when"),
        ({"tags": {"x": float("inf")}}, "step.tags.x"),
        ({"tags": {1: "a"}}, "step.tags[1]"),
    ],
)
def test_invalid_steps_name_the_key_and_the_fix(kwargs, where):
    args = {
        "camera": "spectral",
        "light": "led",
        "exposure_s": 0.1,
        "pattern": {"kind": "full"},
        "tags": {},
    }
    args.update(kwargs)
    with pytest.raises(PlanError) as info:
        Step(**args)
    assert where in str(info.value)
    assert "Fix:" in str(info.value)
    assert isinstance(info.value, ConfigError) and isinstance(info.value, ValueError)


def test_from_dict_names_unknown_and_missing_keys():
    data = golden_plan().to_dict()
    data["steps"][1]["exposure"] = data["steps"][1].pop("exposure_s")
    with pytest.raises(PlanError, match=r"plan\.steps\[1\]\.exposure .*did you mean 'exposure_s'"):
        Plan.from_dict(data)
    data = golden_plan().to_dict()
    del data["steps"][0]["pattern"]
    with pytest.raises(PlanError, match=r"plan\.steps\[0\]\.pattern is missing"):
        Plan.from_dict(data)
    with pytest.raises(PlanError, match=r"plan\.nme"):
        Plan.from_dict({"nme": "x", "steps": []})
    with pytest.raises(PlanError, match="steps is empty"):
        Plan.from_dict({"name": "x", "steps": []})


def test_plan_validation():
    step = golden_plan().steps[0]
    with pytest.raises(PlanError, match="name"):
        Plan("", [step])
    with pytest.raises(PlanError, match=r"steps\[1\]"):
        Plan("p", [step, {"camera": "spectral"}])  # type: ignore[list-item]
    with pytest.raises(PlanError, match="parameters"):
        Plan("p", [step], {"when": object()})


def test_cameras_and_len():
    plan = golden_plan()
    assert len(plan) == 2
    assert plan.cameras == ("spectral", "guide")
    assert list(plan) == list(plan.steps)


def test_concat_records_the_parts():
    a, b = golden_plan(), gray_plan()
    joined = Plan.concat(a, b, name="all")
    assert len(joined) == len(a) + len(b)
    assert joined.steps[len(a)] == b.steps[0]
    parts = joined.to_dict()["parameters"]["parts"]
    assert [(p["name"], p["start"], p["stop"]) for p in parts] == [
        ("golden", 0, 2),
        ("gray-532", 2, 15),
    ]
    assert parts[1]["parameters"] == {"block": 8, "lasers": [532]}
    assert joined.select(role="dark") == [14]
    custom = Plan.concat(a, b, name="all", parameters={"scene": "white"})
    assert dict(custom.parameters) == {"scene": "white"}
    with pytest.raises(PlanError):
        Plan.concat(name="none")


json_leaf = st.none() | st.booleans() | st.integers(-(2**53), 2**53) | st.text(max_size=8)
json_leaf |= st.floats(allow_nan=False, allow_infinity=False)
json_value = st.recursive(
    json_leaf,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=10,
)


@settings(max_examples=60, deadline=None)
@given(tags=st.dictionaries(st.text(max_size=6), json_value, max_size=4), level=json_value)
def test_any_json_round_trips_with_the_same_hash(tags, level):
    plan = Plan("h", [Step("guide", "led", 0.1, {"kind": "uniform", "level": level}, tags)])
    back = Plan.from_dict(json.loads(json.dumps(plan.to_dict())))
    assert back.sha256() == plan.sha256()
    assert back.to_dict() == plan.to_dict()
