"""The blur step's stopping rule and its record."""

from sassi_bench.reduce.blur_budget import (
    BlurBatch,
    BlurFrameRecord,
    blur_frame_settings,
    decide_blur_frames,
)


def test_the_sweeps_frames_suffice_when_the_tolerance_is_met():
    batch = decide_blur_frames(2, 0.049, 0.05, 8)
    assert (batch.next_frames, batch.outcome) == (None, "tolerance met")


def test_the_next_batch_aims_at_the_photon_limited_frames_within_the_budget():
    assert decide_blur_frames(2, 0.0513, 0.05, 8).next_frames == 3  # 2 * 1.026**2 -> 3
    assert decide_blur_frames(2, 0.1, 0.05, 8).next_frames == 8
    assert decide_blur_frames(2, 0.2, 0.05, 8).next_frames == 8  # capped at the budget
    assert decide_blur_frames(8, 0.2, 0.05, 8).outcome == "budget spent"


def test_settings_default_and_never_budget_below_the_sweeps_frames():
    assert blur_frame_settings({"blur": {"frames": 2}}) == (2, 8, 0.05)
    proc = {"blur": {"frames": 3, "max_frames": 2}, "tolerances": {"blur_width_sigma_px": 0.03}}
    assert blur_frame_settings(proc) == (3, 3, 0.03)


def test_a_spent_budget_advises_frames_when_photons_set_the_uncertainty():
    batches = (BlurBatch(2, 0.12, 8, "more frames"), BlurBatch(8, 0.06, None, "budget spent"))
    record = BlurFrameRecord(batches, 0.05, 8)
    assert record.photon_limited()
    assert "take about 12" in record.advice()
    assert record.to_json()["frames_per_laser"] == 8


def test_a_spent_budget_names_the_model_when_frames_did_not_help():
    batches = (BlurBatch(2, 0.08, 8, "more frames"), BlurBatch(8, 0.075, None, "budget spent"))
    record = BlurFrameRecord(batches, 0.05, 8)
    assert record.photon_limited() is False
    assert "more frames will not do" in record.advice()
    assert "blur.field_degree" in record.note()


def test_the_note_names_the_batches_and_the_outcome():
    batches = (BlurBatch(2, 0.0513, 3, "more frames"), BlurBatch(3, 0.0476, None, "tolerance met"))
    note = BlurFrameRecord(batches, 0.05, 8).note()
    assert "3 pinhole frames per laser (2, then 3)" in note
    assert note.endswith("tolerance met")


def test_a_sigma_that_does_not_fall_stops_the_step_with_the_model_named():
    # 0.08 px at 2 frames, 0.079 at 5 and 0.078 at 6: a floor of about 0.077 px twice,
    # above the 0.05 px tolerance, so the budget's 8 frames are not spent on it.
    first = decide_blur_frames(2, 0.08, 0.05, 8)
    assert first.next_frames == 6
    second = decide_blur_frames(5, 0.079, 0.05, 8, [first])
    assert second.outcome == "more frames"  # one pair is not enough to stop
    third = decide_blur_frames(6, 0.078, 0.05, 8, [first, second])
    assert (third.outcome, third.next_frames) == ("out of reach", None)
    record = BlurFrameRecord((first, second, third), 0.05, 8)
    assert "more frames will not do" in record.advice() and "blur.field_degree" in record.note()
