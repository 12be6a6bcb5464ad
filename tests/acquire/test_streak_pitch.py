"""A pinhole pitch too short for the streaks is refused at plan time, before any capture."""

from pathlib import Path

import pytest
import yaml

from sassi_bench import open_rig
from sassi_bench.acquire.streak_pitch import check_scan_pitch, scan_pitch_room
from sassi_bench.errors import ProcedureError
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import load_rig_description
from sassi_bench.workflows.full import run_full_calibration
from sassi_bench.workflows.scan import check_scan

RIGS = Path(__file__).resolve().parents[1] / "rigs"
LONG = str(RIGS / "prism-sf10-80px.yaml")


@pytest.mark.parametrize(
    "rig", ["sim", str(RIGS / "prism-nbk7.yaml"), str(RIGS / "prism-sf10.yaml")]
)
def test_the_test_rigs_streaks_fit_the_nyquist_pitch(rig):
    room = scan_pitch_room(load_rig_description(rig), 100)
    # Free camera columns between neighbouring footprints (as the scan's reading pass marks
    # them: 4 sigmas and 6 px beyond the band) everywhere: 4.6 px on sim, 1.4 on SF10.
    assert room.fits and room.room_px > 1
    check_scan_pitch(load_rig_description(rig), (100, 5))


def test_an_80_px_streak_is_refused_with_the_cause_and_the_fix():
    desc = load_rig_description(LONG)
    room = scan_pitch_room(desc, 100)
    # The streaks touch where the relay's distortion stretches them (the SLM's right edge).
    assert not room.fits and room.room_px < 0
    with pytest.raises(ProcedureError) as caught:
        check_scan_pitch(desc, (100, 5), "Macbeth scan")
    message = str(caught.value)
    assert message.startswith("pinhole scan: the Macbeth scan's streaks")
    assert f"{room.footprint_px:.1f} camera px" in message and "blur" in message
    assert f"at least {room.needed_pitch} SLM px" in message and "Fix:" in message
    # The fix it names works, and one pixel less does not.
    check_scan_pitch(desc, (room.needed_pitch, 5))
    with pytest.raises(ProcedureError):
        check_scan_pitch(desc, (room.needed_pitch - 1, 5))


def test_the_chain_and_a_scan_refuse_a_pitch_override_before_capturing_anything(tmp_path):
    rig = open_rig(LONG)
    with pytest.raises(ProcedureError, match="pinhole scan: the scan's streaks"):
        check_scan(rig, "colorchecker", "led", (100, 5))
    macbeth = load_procedure("macbeth_validation")
    macbeth["scan"]["pitch_px"] = [100, 5]
    macbeth.pop("source")
    (tmp_path / "macbeth.yaml").write_text(yaml.safe_dump(macbeth))
    full = load_procedure("full_calibration")
    full["macbeth_procedure"] = str(tmp_path / "macbeth.yaml")
    with pytest.raises(ProcedureError, match=r"pinhole scan: .*Macbeth scan.*streak-free"):
        run_full_calibration(rig, full, data=tmp_path, session_id="long", progress=False)
    assert not any(tmp_path.rglob("*.zarr")) and not (tmp_path / "staging").exists()
