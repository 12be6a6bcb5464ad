"""The design: section's checks and the as-built overrides (no ray tracer needed)."""

import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.optics.design import OpticalDesign, with_override

BASE = {
    "slm_pixel_pitch_um": 8.0,
    "camera_pixel_pitch_um": 5.5,
    "object_distance_mm": 22.7,
    "aperture": {"object_space_na": 0.02},
    "surfaces": [
        {"thickness_mm": 3.5, "material": "N-BK7", "comment": "collimator"},
        {"radius_mm": -12.92, "thickness_mm": 20.0},
        {"thickness_mm": 4.0, "stop": True},
        {"thickness_mm": 8.0, "material": "N-SF11", "tilt_deg": [0, 27.6, 0]},
        {"thickness_mm": 0.0, "tilt_deg": [0, -2.4, 0]},
        {"coordinate_break": "chief_ray", "thickness_mm": 12.0},
        {"radius_mm": 8.27, "thickness_mm": 2.5, "material": "N-BK7"},
        {"thickness_mm": 13.2},
    ],
}


def _with(**changes):
    data = {**BASE, **changes}
    return data


def test_round_trip_and_hash_ignore_comments():
    design = OpticalDesign.from_mapping(BASE)
    again = OpticalDesign.from_mapping(design.to_mapping())
    assert again == design
    surfaces = [dict(s) for s in BASE["surfaces"]]
    surfaces[0]["comment"] = "another name"
    assert OpticalDesign.from_mapping(_with(surfaces=surfaces)).sha256() == design.sha256()
    surfaces[0]["thickness_mm"] = 3.6
    assert OpticalDesign.from_mapping(_with(surfaces=surfaces)).sha256() != design.sha256()
    assert design.dispersing_glass == "N-SF11"
    # the source file's hash is the rig's business, not the traced grid's
    from_file = OpticalDesign.from_mapping(_with(file_sha256="0" * 64))
    assert from_file.to_mapping()["file_sha256"] == "0" * 64
    assert from_file != design and from_file.sha256() == design.sha256()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"aperture": {"object_na": 0.02}}, "object_space_na"),  # did-you-mean
        ({"aperture": {"object_space_na": 0.02, "working_f_number": 8}}, "exactly one"),
        ({"surfaces": [{"thickness_mm": 1.0}]}, "stop: true"),
        ({"surfaces": [{"thickness_mm": 1.0, "stop": True, "material": "N-BK7"}]}, "in glass"),
        ({"surfaces": [{"thickness_mm": 1.0, "stop": True, "tilt": [0, 1, 0]}]}, "tilt_deg"),
        ({"file": "arm.zmx"}, "read when the rig loads"),
        ({"file_sha256": "abc"}, "not a SHA-256"),
    ],
)
def test_bad_designs_are_refused_with_the_key(change, message):
    with pytest.raises(ConfigError, match=message) as info:
        OpticalDesign.from_mapping(_with(**change))
    assert "Fix:" in str(info.value)


def test_coordinate_break_takes_no_optical_keys():
    surfaces = [*BASE["surfaces"]]
    surfaces[5] = {"coordinate_break": "chief_ray", "radius_mm": 5.0}
    with pytest.raises(ConfigError, match=r"surfaces\[6\]"):
        OpticalDesign.from_mapping(_with(surfaces=surfaces))


def test_as_built_override_changes_only_the_named_surface():
    design = OpticalDesign.from_mapping(BASE)
    built = with_override(
        design, {"surfaces": {"7": {"decenter_mm": [0.2, 0.0]}, 8: {"thickness_mm": 13.3}}}
    )
    assert built.surfaces[6].decenter_mm == (0.2, 0.0)
    assert built.surfaces[7].thickness_mm == 13.3
    assert built.surfaces[:6] == design.surfaces[:6]
    assert built.sha256() != design.sha256()
    with pytest.raises(ConfigError, match=r"surfaces 1\.\.8"):
        with_override(design, {"surfaces": {"9": {"thickness_mm": 1.0}}})
    with pytest.raises(ConfigError, match="radius_mm"):
        with_override(design, {"surfaces": {"2": {"radius": 1.0}}})
