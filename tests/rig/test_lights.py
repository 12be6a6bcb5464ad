"""Every registered light kind holds to the same contract (a new kind adds its lights to
the rig below, or a rig of its own, and passes these)."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.optics.sources import wavelength_grid
from sassi_bench.rig.config import load_rig_description
from sassi_bench.rig.lights import LIGHT_KINDS, kind_of, light_kinds, light_names

DESC = load_rig_description("sim")
GRID = wavelength_grid(390.0, 720.0, 2.0)


def test_every_light_of_the_rig_belongs_to_one_kind_and_every_kind_has_lights():
    owners = {light: [type(k).__name__ for k in light_kinds() if k.owns(light.lower())]
              for light in DESC.light_names}  # fmt: skip
    assert all(len(kinds) == 1 for kinds in owners.values()), owners
    kinds = {kinds[0] for kinds in owners.values()}
    assert kinds == {cls.__name__ for _, cls in LIGHT_KINDS.items()}


@pytest.mark.parametrize("light", DESC.light_names)
def test_a_light_s_name_instruction_and_spectrum(light):
    kind = kind_of(light)
    assert kind.canonical(light.lower()).lower() == light.lower()  # already canonical
    assert kind.instruction(light).startswith("Switch")
    samples = kind.samples(light, GRID, kind.settings(light, DESC))
    assert np.all(np.isfinite(samples.wavelengths_nm)) and np.all(samples.weights >= 0)
    if light != "off":
        assert samples.weights.sum() > 0


def test_kinds_list_their_lights_in_the_rig_s_order():
    assert light_names((450.0, 532.0), ("Ne", "HgAr")) == (
        "off", "laser:450", "laser:532", "led", "halogen", "fluorescent", "lamp:Ne", "lamp:HgAr",
    )  # fmt: skip


def test_only_lasers_are_coherent():
    assert [light for light in DESC.light_names if kind_of(light).coherent] == [
        f"laser:{x:g}" for x in DESC.lasers_nm
    ]


def test_an_unknown_light_has_no_kind():
    with pytest.raises(KeyError):
        kind_of("strobe")
