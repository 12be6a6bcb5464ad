from sassi_bench.reduce.blur_budget import BlurBatch, BlurFrameRecord
from sassi_bench.reduce.response_budget import (
    ResponseBatch,
    ResponseFrameRecord,
    ResponseSettings,
)


def test_a_sigma_falling_as_photon_noise_is_photon_limited_and_one_that_stalls_is_not():
    falls = (BlurBatch(2, 0.08, 8, "more frames"), BlurBatch(8, 0.041, None, "tolerance met"))
    stalls = (BlurBatch(2, 0.08, 8, "more frames"), BlurBatch(8, 0.075, None, "budget spent"))
    assert BlurFrameRecord(falls, 0.05, 8).photon_limited() is True
    assert BlurFrameRecord(stalls, 0.05, 8).photon_limited() is False
    assert BlurFrameRecord(falls[:1], 0.05, 8).photon_limited() is None


def test_every_record_reads_its_own_sigma_and_its_last_batch():
    batches = (
        ResponseBatch(20, 0.012, 0.08, 52, "more frames"),
        ResponseBatch(52, 0.0075, 0.049, None, "tolerance met"),
    )
    settings = ResponseSettings(20, 80, 0.05)
    record = ResponseFrameRecord(batches, settings, 25)
    assert (record.frames, record.outcome, record.taken()) == (52, "tolerance met", "20, then 52")
    assert record.photon_limited() is True  # 0.08 * sqrt(20 / 52) = 0.050
    assert record.advice() is None and record.note().endswith(": tolerance met")
    spent = ResponseFrameRecord(
        (ResponseBatch(80, 0.012, 0.06, None, "budget spent"),), settings, 25
    )
    assert spent.note().endswith(spent.advice()) and "take about 116" in spent.note()
