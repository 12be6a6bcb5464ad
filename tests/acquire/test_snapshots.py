"""Snapshot capture: masks stored exactly, a video planned frame by frame, resumable."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import pixels_descriptor, render_pattern
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.snapshots import CLOSED_STEP, capture_snapshots, snapshot_mask
from sassi_bench.errors import ProcedureError
from sassi_bench.rig.scene_pose import ScenePose

EXPOSE = {"kind": "pinholes", "pitch": [80, 5]}


def test_pixels_descriptor_round_trips_an_arbitrary_mask():
    rng = np.random.default_rng(3)
    mask = rng.random((40, 64)) < 0.01
    back = render_pattern(pixels_descriptor(mask), mask.shape) > 0
    assert np.array_equal(back, mask)


def test_pixels_outside_the_slm_are_refused():
    with pytest.raises(ProcedureError, match="outside the 6x4 SLM"):
        render_pattern({"kind": "pixels", "rows": [0, 4], "cols": [1, 2]}, (4, 6))


class _MaskFromGuide:
    """A mask that depends on the guide image it is given (and counts its calls)."""

    def __init__(self, shape):
        self.shape, self.calls = shape, 0

    def __call__(self, guide):
        self.calls += 1
        mask = np.zeros(self.shape, bool)
        offset = int(guide[..., 1].mean()) % 40  # differs from frame to frame
        mask[2::5, offset::80] = True
        return mask


@pytest.fixture(scope="module")
def rig():
    return open_rig("sim")


def test_video_masks_follow_the_previous_guide_and_resume(rig, tmp_path):
    masks = _MaskFromGuide(rig.slm.shape)
    motion = ((3.0, 1.0), 0.5)
    kwargs = dict(
        prefix="v", scene="pcb", exposure_pattern=EXPOSE, motion=motion, data=tmp_path,
        progress=False, low_light=0.1,
    )  # fmt: skip
    first = capture_snapshots(rig, masks, frames=1, **kwargs)
    assert masks.calls == 1
    # Frame t's mask is the function of frame t-1's stored guide image.
    assert np.array_equal(first.mask(0), _MaskFromGuide(rig.slm.shape)(first.guide(-1)))
    # Resuming keeps the finished frames and plans only the new one.
    again = capture_snapshots(rig, masks, frames=2, **kwargs)
    assert masks.calls == 2
    assert again.frames[0].sha256() == first.frames[0].sha256()
    assert np.array_equal(again.mask(1), _MaskFromGuide(rig.slm.shape)(again.guide(0)))
    assert again.pose(1) == ScenePose((3.0, 1.0), 0.5)
    assert not np.array_equal(again.guide(0), again.guide(1))  # the scene moved
    # Everything needed to read a frame back is in its session on disk.
    session = Session.open("v-f001", data=tmp_path)
    assert np.array_equal(snapshot_mask(session), again.mask(1))
    assert session.plan.parameters["exposures"]["low_light"] == 0.1
    assert session.read_frame(1).shape == rig.spectral_camera.shape
    assert again.closed(1) is None  # no closed-SLM frame asked for


def test_a_snapshot_may_take_the_closed_slm_at_its_exposure(rig, tmp_path):
    mask = np.zeros(rig.slm.shape, bool)
    mask[2::5, 10::80] = True
    video = capture_snapshots(
        rig, lambda guide: mask, prefix="c", scene="natural", exposure_pattern=EXPOSE,
        closed_frame=True, data=tmp_path, progress=False,
    )  # fmt: skip
    step = video.frames[0].plan.steps[CLOSED_STEP]
    assert step.pattern == {"kind": "blank"} and step.tags["role"] == "closed"
    assert step.exposure_s == video.exposures.spectral_s
    frame, closed = video.spectral(0).astype(float), video.closed(0).astype(float)
    light = frame - closed
    # The closed frame holds the leak and no streak (measured: 99.9th percentile 2421 ADU,
    # the snapshot's brightest pixel 50165); off the streaks the two frames agree (median
    # |difference| 47 ADU on a leak of 484).
    assert np.percentile(closed, 99.9) < 0.1 * frame.max()
    assert np.median(np.abs(light)) < 0.2 * np.median(closed)


def test_mask_of_a_session_that_is_not_a_snapshot_is_refused(tmp_path, rig):
    from sassi_bench.acquire.plan import Plan, Step

    plan = Plan("dark", [Step("spectral", "off", 0.01, {"kind": "blank"})])
    session = Session.create(rig.description, plan, session_id="d", data=tmp_path)
    with pytest.raises(ProcedureError, match="not a snapshot frame"):
        snapshot_mask(session)
