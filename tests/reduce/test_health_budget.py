"""The health check's stopping rule and its record."""

from sassi_bench.reduce.health_budget import (
    ShiftBatch,
    ShiftFrameRecord,
    decide_shift_frames,
    shift_frame_settings,
)


def test_one_frame_suffices_when_the_map_is_confident():
    batch = decide_shift_frames(1, 0.0015, 0.002, 0.03, 8)  # sim: 0.0015 px after one frame
    assert (batch.next_frames, batch.outcome) == (None, "tolerance met")


def test_the_next_batch_aims_at_the_photon_limited_frames_within_the_budget():
    assert decide_shift_frames(1, 0.05, 0.0, 0.03, 8).next_frames == 3  # 1 * (5/3)**2 -> 3
    assert decide_shift_frames(1, 0.2, 0.0, 0.03, 8).next_frames == 8  # capped at the budget
    assert decide_shift_frames(8, 0.2, 0.0, 0.03, 8).outcome == "budget spent"


def test_settings_default_and_never_budget_below_the_first_batch():
    assert shift_frame_settings({"frames": 1, "tolerances": {}}) == (1, 8, 0.03)
    proc = {"frames": 3, "max_frames": 2, "tolerances": {"shift_sigma_px": 0.01}}
    assert shift_frame_settings(proc) == (3, 3, 0.01)


def test_a_spent_budget_advises_frames_when_photons_set_the_uncertainty():
    batches = (
        ShiftBatch(1, 0.08, 0.1, 8, "more frames"),
        ShiftBatch(8, 0.04, 0.1, None, "budget spent"),
    )
    record = ShiftFrameRecord(batches, 0.03, 8)
    assert record.photon_limited()
    assert "take about 15" in record.advice()  # 8 * (0.04 / 0.03)**2 = 14.2
    assert record.to_json()["frames"] == 8


def test_a_spent_budget_names_the_map_when_frames_did_not_help():
    batches = (
        ShiftBatch(1, 0.05, 0.1, 8, "more frames"),
        ShiftBatch(8, 0.045, 0.1, None, "budget spent"),
    )
    record = ShiftFrameRecord(batches, 0.03, 8)
    assert record.photon_limited() is False
    assert "more frames will not do" in record.note()
    assert "field_degree" in record.advice()
