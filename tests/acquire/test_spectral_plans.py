"""The blur frames' pinhole pattern reaches the SLM's edges."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.acquire.spectral_plans import blur_pinholes


@pytest.mark.parametrize(
    ("pitch", "shape"), [([40, 40], (200, 320)), ([26, 26], (400, 640)), ([33, 17], (480, 640))]
)
def test_blur_pinholes_span_the_field_at_least_the_pitch_apart(pitch, shape):
    pattern = blur_pinholes(pitch, shape)
    rows, cols = open_pixels(pattern, shape)
    for got, size, least in ((cols, shape[1], pitch[0]), (rows, shape[0], pitch[1])):
        at = np.unique(got)
        assert np.diff(at).min() >= least
        # the outermost pinholes within a pitch's remainder of the edges
        assert at[0] <= (size - 1) % least and at[-1] >= size - 1 - (size - 1) % least
        assert at.size == (size - 1) // least + 1


def test_a_pitch_wider_than_the_slm_keeps_one_pinhole_in_the_middle():
    rows, cols = open_pixels(blur_pinholes([400, 40], (200, 320)), (200, 320))
    assert set(cols.tolist()) == {160}
    assert rows.min() <= 3 and rows.max() >= 196


def test_the_field_blur_lamp_lines_are_strong_clear_lines_past_the_lasers():
    from sassi_bench.acquire.spectral_plans import blur_lamp_lines
    from sassi_bench.rig.config import load_rig_description

    desc = load_rig_description("sim-singlet")
    tables = desc.lamp_lines()
    lasers = (450.0, 520.0, 532.0, 635.0, 670.0)
    # Hg 404.7 (407.8 nm beside it has 7 % of its light) and 435.8 nm; the Ne lines past
    # 670 nm come in pairs 10 nm apart (692.9, 703.2), the Ar lines are weak
    assert blur_lamp_lines(tables["HgAr"], lasers, desc).tolist() == [404.6565, 435.8335]
    assert blur_lamp_lines(tables["Ne"], lasers, desc).size == 0
    # lasers reaching the blue end leave nothing to measure there
    assert blur_lamp_lines(tables["HgAr"], (405.0, 440.0, 670.0), desc).size == 0


def test_field_lamps_get_pinhole_frames_at_offsets_over_one_pitch():
    from sassi_bench.acquire.patterns import open_pixels
    from sassi_bench.acquire.spectral_plans import LAMP_FIELD_OFFSETS, lamp_plan

    procedure = {"lamps": {"pinhole_pitch_px": [155, 27], "frames": 3}}
    exposures = {"lamp:HgAr": 0.05, "lamp:Ne": 0.1}
    plain = lamp_plan(procedure, exposures)
    assert plain.select(role="lamp-field") == []
    plan = lamp_plan(procedure, exposures, field_lamps=["lamp:HgAr"])
    field = plan.select(role="lamp-field")
    assert len(plan) == len(plain) + len(field)
    # each offset as many times as the lamp's pinhole frames planned
    assert len(field) == LAMP_FIELD_OFFSETS * 3
    assert {plan.steps[i].tags["lamp"] for i in field} == {"lamp:HgAr"}
    assert max(plan.steps[i].tags["frame"] for i in field) == 2
    # a budget under the first batch caps them; one over it plans them to the budget
    small = lamp_plan(procedure, exposures, frames=2, field_lamps=["lamp:HgAr"])
    assert len(small.select(role="lamp-field")) == LAMP_FIELD_OFFSETS * 2
    budget = lamp_plan(procedure, exposures, frames=8, field_lamps=["lamp:HgAr"])
    assert len(budget.select(role="lamp-field")) == LAMP_FIELD_OFFSETS * 8
    columns = set()
    for i in field:
        columns |= set(open_pixels(plan.steps[i].pattern, (200, 320))[1].ravel().tolist())
    # the offsets spread the pinholes' columns over the field, from its left edge to
    # within a quarter pitch of its right edge
    assert min(columns) == 0 and max(columns) >= 319 - 155 // 4
    assert len(columns) == 2 * LAMP_FIELD_OFFSETS + 1  # 3, 2, 2, 2 columns per offset
    # given the SLM's shape, the last offset puts pinholes on its right and bottom edges
    edges = lamp_plan(procedure, exposures, field_lamps=["lamp:HgAr"], slm_shape=(200, 320))
    rows, columns = set(), set()
    for i in edges.select(role="lamp-field"):
        r, c = open_pixels(edges.steps[i].pattern, (200, 320))
        rows |= set(r.ravel().tolist())
        columns |= set(c.ravel().tolist())
    assert {0, 319} <= columns and {0, 199} <= rows
