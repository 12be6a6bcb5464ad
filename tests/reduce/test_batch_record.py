from sassi_bench.reduce.blur_budget import BlurBatch, BlurFrameRecord
from sassi_bench.reduce.response_budget import ResponseBatch, ResponseFrameRecord


def test_a_sigma_falling_as_photon_noise_is_photon_limited_and_one_that_stalls_is_not():
    falls = (BlurBatch(2, 0.08, 8, "more frames"), BlurBatch(8, 0.041, None, "tolerance met"))
    stalls = (BlurBatch(2, 0.08, 8, "more frames"), BlurBatch(8, 0.075, None, "budget spent"))
    assert BlurFrameRecord(falls, 0.05, 8).photon_limited() is True
    assert BlurFrameRecord(stalls, 0.05, 8).photon_limited() is False
    assert BlurFrameRecord(falls[:1], 0.05, 8).photon_limited() is None


def test_every_record_reads_its_own_sigma_and_its_last_batch():
    batches = (
        ResponseBatch(20, 0.008, 52, "more frames"),
        ResponseBatch(52, 0.0049, None, "tolerance met"),
    )
    record = ResponseFrameRecord(batches, 0.005, 80, 25)
    assert (record.frames, record.outcome, record.taken()) == (52, "tolerance met", "20, then 52")
    assert record.photon_limited() is True  # 0.008 * sqrt(20 / 52) = 0.0050
    assert record.advice() is None and record.note().endswith("): tolerance met")
    spent = ResponseFrameRecord((ResponseBatch(80, 0.006, None, "budget spent"),), 0.005, 80, 25)
    assert spent.note().endswith(spent.advice()) and "take about 116" in spent.note()
