"""Canonical JSON: the bytes every recorded hash was taken over must never change.

Before one helper there were three encoders (capture plans, bundles, rig descriptions);
each pin below is the bytes or hash the old encoder of that caller produced, so sessions
and bundles recorded before keep their identity.
"""

from __future__ import annotations

import hashlib
import json
import math

import pytest

from sassi_bench._shared.canonical_json import canonical_json, canonical_sha256
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session.events import EventLog
from sassi_bench.rig.config import load_rig_description

#: Sorted keys, nesting, non-ASCII text, floats in exponent form, booleans and null.
VALUE = {
    "name": "lab rig",
    "units": "µm",
    "lasers_nm": [450, 520.5, 638],
    "nested": {"b": None, "a": True, "z": -1e-07},
    "big": 1.5e300,
}
VALUE_BYTES = (
    b'{"big":1.5e+300,"lasers_nm":[450,520.5,638],"name":"lab rig",'
    b'"nested":{"a":true,"b":null,"z":-1e-07},"units":"\\u00b5m"}'
)
VALUE_SHA256 = "86f07c9c2230dd6dfcbbbfacc2808fd50920dcd516ee4a0d9ea85f3c85bf67c4"


def test_the_canonical_bytes_of_a_known_value_are_pinned():
    assert canonical_json(VALUE) == VALUE_BYTES
    assert canonical_sha256(VALUE) == VALUE_SHA256 == hashlib.sha256(VALUE_BYTES).hexdigest()


def test_key_order_does_not_change_the_bytes():
    assert canonical_json(dict(reversed(list(VALUE.items())))) == VALUE_BYTES


def test_plan_and_bundle_encoders_gave_these_bytes():
    # acquire.plan and bundle.jsonio both encoded ASCII text made this way.
    legacy = json.dumps(VALUE, sort_keys=True, separators=(",", ":"), allow_nan=False)
    assert legacy.encode("ascii") == canonical_json(VALUE)


def test_rig_description_hash_bytes_are_unchanged():
    # RigDescription.sha256 hashes dumps(sort_keys, compact).encode(): UTF-8 of ASCII text.
    legacy = json.dumps(VALUE, sort_keys=True, separators=(",", ":")).encode()
    assert legacy == canonical_json(VALUE)
    # The sim rig has no hardware section, so its hash is that of its canonical form.
    rig = load_rig_description("sim")
    assert rig.sha256() == canonical_sha256(rig.to_dict())


def test_plan_hash_is_pinned():
    plan = Plan(
        "gray 532",
        [
            Step(
                "spectral",
                "laser:532",
                0.25,
                {"kind": "pinholes", "pitch": [100, 50], "offset": [3, 0]},
                {"role": "pinholes"},
            ),
            Step("guide", "led", 0.01, {"kind": "blank"}),
        ],
    )
    assert plan.sha256() == "66cfca5da3b15c69907eaa946c4d7e14e4e74adcb61a086bc3a8860872d79599"
    assert plan.sha256() == canonical_sha256(plan.to_dict())


def test_session_event_line_bytes_are_pinned(tmp_path):
    (tmp_path / "events.jsonl").write_bytes(b"")
    log = EventLog(tmp_path, [("spectral", 0)] * 3 + [("guide", 1)], "session 't'")
    event = {
        "step": 3,
        "camera": "guide",
        "slot": 1,
        "meta": {"camera": "guide", "exposure_s": 0.01, "extra": {"gain_dB": 1.5, "note": "Ø"}},
        "pattern": {"kind": "blank"},
        "tags": {},
        "sha256": "ab" * 32,
        "dtype": "|u1",
        "shape": [4, 5, 3],
        "written": "2025-01-01T00:00:00.000Z",
    }
    log.append(event)
    line = (tmp_path / "events.jsonl").read_bytes()
    assert line.endswith(b"}\n") and b'"note":"\\u00d8"' in line
    assert hashlib.sha256(line).hexdigest() == (
        "247b4ce98574fae350769028578edddd1f7f4e4ad8d59ee3b1956eb8bd772eff"
    )


@pytest.mark.parametrize("number", [math.nan, math.inf, -math.inf])
def test_non_finite_numbers_are_refused(number):
    with pytest.raises(ValueError, match="not JSON compliant"):
        canonical_json({"x": [number]})
