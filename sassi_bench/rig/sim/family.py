"""A seeded family of virtual benches spanning what labs build, each built off its
description by a datasheet's tolerance.

Each rig is a description as a lab would write it (catalogue glass, drawing apex,
datasheet camera, lasers by their labels) and the bench-only ``as_built`` section with how
this bench really is. Drawn per rig: a glass from N-BK7 to SF10/N-SF11 (30 degree apex), a
400-700 nm spread of 40-140 px, an SLM from 640 x 480 to 1920 x 1080 (``small``: 320 x 240
to 480 x 270, the fast subset), a relay scale of 0.95-1.2 rotated within +-2 degrees, a
camera of 2-10 e- read noise and 10k-60k e- full well, an SLM contrast of 200-2000
(log-uniform), a fill factor of 0.85-0.97, a PSF of 1.2-3 px at the band's ends and 0.4-1 px
in its middle, 4 to 6 lasers (diode lines within +-5 nm of their labels; DPSS, OPSL and HeNe
lines exact), HgAr and Ne lamps on every other rig. A rig with lamps describes its lasers by
their labels; one without (no wavelength reference but its lasers' test sheets) describes
each diode by its test sheet's measured centre, off the true line by the sheet's accuracy
(a 2-sigma of 0.2-0.3 nm drawn per rig, stated as the rig's ``laser_tolerance_nm``), while
the bench keeps the true lines. As built, by a datasheet's tolerance
(one sigma): the relay's scale 1 %, its rotation 0.1 degree and offset 1 px, the fill
factor 0.01, the PSF 10 %, the read noise 10 %, the gain 3 %, the full well 3 %, the glass
melt 0.0005 in index, the apex 0.05 degree, the halogen lamp 60 K, the SLM gamma 0.1, the
lamp lines' intensities 30 %. The spectral camera is sized to the SLM's image and its
streaks and centred on them through the described relay.

Used by ``benchmarks/rig_family.py`` and the family tests; the rigs are virtual benches,
so this lives with the bench (procedures never see ``as_built``).
"""

from __future__ import annotations

import copy
import math
from importlib import resources
from typing import Any

import numpy as np
import yaml

from sassi_bench.errors import SassiBenchError
from sassi_bench.rig.config import rig_description_from_dict

__all__ = ["GLASSES", "family_rig", "family_rigs", "measured_laser_lines"]

#: Glasses, from low to high dispersion.
GLASSES = ("N-BK7", "F2", "N-SF5", "SF10", "N-SF11")
_SLM_FULL = ((640, 480), (800, 600), (1024, 768), (1280, 720), (1920, 1080))
_SLM_SMALL = ((320, 240), (384, 216), (400, 300), (448, 336), (480, 270))
#: Laser label -> its kind: a diode is off its label by up to 5 nm, the others are exact.
_LASERS = {405: "diode", 445: "diode", 450: "diode", 473: "dpss", 488: "opsl", 515: "diode",
           520: "diode", 532: "dpss", 561: "dpss", 594: "hene", 633: "hene", 635: "diode",
           638: "diode", 640: "diode", 660: "diode", 670: "diode"}  # fmt: skip
_BLUE = (405, 445, 450, 473)
_RED = (633, 635, 638, 640, 660, 670)
_MIDDLE = (488, 515, 520, 532, 561, 594)


def _base() -> dict[str, Any]:
    text = resources.files("sassi_bench.procedures").joinpath("rigs", "sim.yaml").read_text()
    return yaml.safe_load(text)


def _lasers(rng: np.random.Generator) -> list[int]:
    """4 to 6 labels: one blue, one red, the rest from the middle, at least 8 nm apart."""
    while True:
        n = int(rng.integers(4, 7))
        picked = {int(rng.choice(_BLUE)), int(rng.choice(_RED))}
        picked |= {int(x) for x in rng.choice(_MIDDLE, size=n - 2, replace=False)}
        labels = sorted(picked)
        kept = [labels[0]]
        for label in labels[1:]:
            if label - kept[-1] >= 8:
                kept.append(label)
        if len(kept) >= 4:
            return kept


def _r(value: float, digits: int) -> float:
    return float(np.round(value, digits))


def family_rig(rng: np.random.Generator, index: int, small: bool, lamps: bool) -> dict[str, Any]:
    """One rig of the family, drawn with ``rng`` (see the module docstring).

    Returns
    -------
    dict
        A rig description with its ``as_built`` section, ready for
        :func:`~sassi_bench.rig.config.rig_description_from_dict` or a YAML file.

    Examples
    --------
    >>> rig = family_rig(np.random.default_rng(1), 0, small=True, lamps=True)
    >>> rig["name"].startswith("fam00-"), rig["wavelength_lamps"], "relay_scale" in rig["as_built"]
    (True, ['HgAr', 'Ne'], True)
    """
    glass = str(rng.choice(GLASSES))
    spread = _r(rng.uniform(40, 140), 1)
    w, h = (_SLM_SMALL if small else _SLM_FULL)[int(rng.integers(0, 5))]
    scale = _r(rng.uniform(0.95, 1.2), 3)
    rotation = _r(rng.uniform(-2, 2), 2)
    read = _r(rng.uniform(2, 10), 1)
    well = _r(rng.uniform(10_000, 60_000), -2)
    contrast = _r(math.exp(rng.uniform(math.log(200), math.log(2000))), 0)
    fill = _r(rng.uniform(0.85, 0.97), 3)
    sharp = _r(rng.uniform(0.4, 1.0), 2)
    blue, red = _r(rng.uniform(1.2, 3.0), 2), _r(rng.uniform(1.2, 3.0), 2)
    lasers = _lasers(rng)
    true_lasers = {
        label: _r(label + rng.uniform(-5, 5), 2) for label in lasers if _LASERS[label] == "diode"
    }
    name = f"fam{index:02d}-{glass.lower()}-{int(spread)}px-{w}x{h}" + ("-lamps" if lamps else "")
    seed = int(rng.integers(1, 2**31 - 1))
    rig = _base()
    rig.update(
        {
            "name": name,
            "description": (
                f"family rig {index}: {glass} {spread} px, SLM {w}x{h}, read {read} e-, well "
                f"{well:.0f} e-, contrast {contrast:.0f}, rotation {rotation} deg, lasers "
                f"{lasers}" + (", HgAr+Ne" if lamps else ", test-sheet lines")
            ),
            "seed": seed,
        }
    )
    rig["slm"].update({"width": w, "height": h, "contrast_ratio": contrast, "fill_factor": fill})
    rig["spectral_camera"].update({"read_noise_e": read, "full_well_e": well})
    rig["relay"].update(
        {"scale": scale, "rotation_deg": rotation, "offset_px": [0.0, 0.0],
         "distortion_k1": _r(rng.uniform(0.0, 0.008), 4)}
    )  # fmt: skip
    rig["prism"].update(
        {"glass": glass, "apex_deg": 30, "spread_px": spread,
         "smile_px": _r(rng.uniform(0.3, 1.2), 2)}
    )  # fmt: skip
    rig["blur"] = {"sigma_px": {405: blue, 530: sharp, 660: red}}
    rig["guide_camera"].update(
        {"width": int(math.ceil(w * 0.9 / 8) * 8) + 40,
         "height": int(math.ceil(h * 0.9 / 8) * 8) + 24}
    )  # fmt: skip
    rig["lasers_nm"] = lasers
    if lamps:
        rig["wavelength_lamps"] = ["HgAr", "Ne"]
    else:
        rig.pop("wavelength_lamps", None)
        if true_lasers:
            described, accuracy = measured_laser_lines(seed, true_lasers)
            rig["lasers_nm"] = [described.get(label, label) for label in lasers]
            rig["laser_tolerance_nm"] = {m: accuracy for m in described.values()}
            true_lasers = {described[label]: line for label, line in true_lasers.items()}
    rig = _fit_camera(rig)
    offset = rig["relay"]["offset_px"]
    camera = rig["spectral_camera"]
    gain = well / (2 ** camera["bit_depth"] - 1 - camera["dark_offset_adu"])  # as described
    rig["as_built"] = {
        **({"lasers_nm": true_lasers} if true_lasers else {}),
        "glass_index_offset": _r(rng.normal(0, 0.0005), 5),
        "apex_deg": _r(30 + rng.normal(0, 0.05), 3),
        "halogen_k": _r(3000 + rng.normal(0, 60), 0),
        "slm_gamma": _r(2.2 + rng.normal(0, 0.1), 3),
        "lamp_intensity_spread": 0.3,
        "relay_scale": _r(scale * (1 + rng.normal(0, 0.01)), 4),
        "relay_rotation_deg": _r(rotation + rng.normal(0, 0.1), 3),
        "relay_offset_px": [_r(x + rng.normal(0, 1), 2) for x in offset],
        "fill_factor": _r(min(0.99, fill + rng.normal(0, 0.01)), 3),
        "blur_scale": _r(1 + rng.normal(0, 0.1), 3),
        "read_noise_e": _r(read * (1 + rng.normal(0, 0.1)), 2),
        "gain_e_per_adu": _r(gain * (1 + rng.normal(0, 0.03)), 4),
        "full_well_e": _r(well * (1 + rng.normal(0, 0.03)), -1),
    }
    rig_description_from_dict(rig)  # the bench as built loads too
    return rig


#: The test sheets' own random stream beside the rig's seed, so their draw moves no other.
_TEST_SHEET_STREAM = 45


def measured_laser_lines(seed: int, true_lines: dict[int, float]) -> tuple[dict[int, float], float]:
    """What the diodes' test sheets state: each line's measured centre, off the true line
    by the sheet's accuracy (its 2-sigma, 0.2-0.3 nm, drawn from ``seed``).

    Drawn from a generator of the rig's own ``seed``, so stating the lines leaves every
    other draw of the family as it was.

    Returns
    -------
    dict, float
        Label -> the sheet's measured centre (nm, 0.01 nm), and the sheet's accuracy (nm).

    Examples
    --------
    >>> sheet, accuracy = measured_laser_lines(7, {520: 522.34, 635: 633.0})
    >>> 0.2 <= accuracy <= 0.3, all(abs(sheet[k] - v) < 4 * accuracy for k, v in
    ...                            {520: 522.34, 635: 633.0}.items())
    (True, True)
    """
    rng = np.random.default_rng([seed, _TEST_SHEET_STREAM])
    accuracy = _r(rng.uniform(0.2, 0.3), 2)
    sheet = {label: _r(line + rng.normal(0, accuracy / 2), 2) for label, line in true_lines.items()}
    return sheet, accuracy


def _fit_camera(rig: dict[str, Any]) -> dict[str, Any]:
    """Size the spectral camera to the SLM's image and its streaks with a margin, and
    centre the streaked image on it through the described relay."""
    w, h = rig["slm"]["width"], rig["slm"]["height"]
    s = rig["relay"]["scale"]
    cw = int(math.ceil((w * s + 1.6 * rig["prism"]["spread_px"] + 80) / 16) * 16)
    ch = int(math.ceil((h * s + 60) / 16) * 16)
    for _ in range(12):
        rig["spectral_camera"].update({"width": cw, "height": ch})
        rig["relay"]["offset_px"] = [0.0, 0.0]
        big = copy.deepcopy(rig)
        big["spectral_camera"].update({"width": cw * 2, "height": ch * 2})
        relay = rig_description_from_dict(big).nominal_relay()
        u = np.array([0, w - 1, 0, w - 1], dtype=float)[:, None]
        v = np.array([0, 0, h - 1, h - 1], dtype=float)[:, None]
        x, y = relay.forward(u, v, np.array([400.0, 700.0])[None, :])
        cx, cy = (x.min() + x.max()) / 2 - cw, (y.min() + y.max()) / 2 - ch
        rig["relay"]["offset_px"] = [_r(-cx, 1), _r(-cy, 1)]
        try:
            rig_description_from_dict(rig)
            return rig
        except SassiBenchError:
            cw, ch = int(cw * 1.08 // 16 * 16 + 16), int(ch * 1.05 // 16 * 16 + 16)
    raise SassiBenchError(f"rig family: no spectral camera fits {rig['name']}")


def family_rigs(seed: int = 45, count: int = 24, small: bool = False) -> list[dict[str, Any]]:
    """``count`` rigs of the family drawn from ``seed``; every other one with lamps.

    Examples
    --------
    >>> rigs = family_rigs(45, 2, small=True)
    >>> len(rigs), "wavelength_lamps" in rigs[1]
    (2, True)
    """
    rng = np.random.default_rng(seed)
    return [family_rig(rng, i, small, lamps=bool(i % 2)) for i in range(count)]
