"""Write ``sim-achromat.zmx``: the shipped achromat arm (procedures/rigs/sim-achromat.yaml)
as a Zemax OpticStudio sequential file, the fixture of tests/optics/design/test_zemax.py.

Run once from the repository's root (``python tests/optics/data/make_sim_achromat_zmx.py``);
the file is kept in git. Each tilted prism face is written as OpticStudio's Tilt/Decenter
Elements tool writes it (a break, the surface, the break that restores the axis, order 1);
the chief-ray fold is solved by tracing the design and written as a numeric break.
"""

from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from sassi_bench.optics.design import OpticalDesign
from sassi_bench.optics.design.build import build_design

ROOT = Path(__file__).resolve().parents[3]
OUT = Path(__file__).with_name("sim-achromat.zmx")


def _surface(lines, number, kind="STANDARD", curv=0.0, thickness=0.0):
    lines += [f"SURF {number}", f"  TYPE {kind}", f"  CURV {curv:.17E}", f"  DISZ {thickness:.17E}"]


def _break(lines, number, thickness, decenter=(0.0, 0.0), tilt=(0.0, 0.0, 0.0), order=0):
    _surface(lines, number, "COORDBRK", 0.0, thickness)
    values = [*decenter, *tilt, float(order)]
    lines += [f"  PARM {k} {v:.17E}" for k, v in enumerate(values, 1)]


def main() -> None:
    from optiland.materials import MaterialFile  # the design extra

    rig = yaml.safe_load((ROOT / "procedures/rigs/sim-achromat.yaml").read_text())
    design = OpticalDesign.from_mapping(rig["design"])
    built = build_design(design, (200, 320), (288, 512))
    placed, _ = built._place()
    frames = {p.index: p.frame for p in placed}
    kind, value = design.aperture
    assert kind == "object_space_na"
    lines = [
        "VERS 190513 80 123457 L123457",
        "MODE SEQ",
        "NAME sim-achromat spectral arm (SLM to camera)",
        "UNIT MM X W X CM MR CPMM",
        f"OBNA {value:.17E} 0",
        "GCAT SCHOTT",
        "FTYP 1 0 1 1 0 0 0",
        "XFLN 0",
        "YFLN 0",
        f"WAVM 1 {design.reference_nm * 1e-3:.17E} 1",
        "PWAV 1",
    ]
    _surface(lines, 0, thickness=design.object_distance_mm)
    number = 1
    running = (np.array([0.0, 0.0, design.object_distance_mm]), np.eye(3))  # the axis
    for index, s in enumerate(design.surfaces, 1):
        if s.coordinate_break == "chief_ray":
            origin, axes = running
            after = frames[index + 1]  # the next surface is untilted: its frame is the axis
            point = after.origin - s.thickness_mm * after.axes[:, 2]
            shift = axes.T @ (point - origin)
            assert abs(shift[2]) < 1e-9, shift
            tilt = Rotation.from_matrix(axes.T @ after.axes).as_euler("XYZ", degrees=True)
            _break(lines, number, s.thickness_mm, tuple(shift[:2]), tuple(tilt))
            running = (point + s.thickness_mm * after.axes[:, 2], after.axes)
            number += 1
            continue
        assert not s.is_break
        tilted = s.is_tilted or any(s.decenter_mm)
        if tilted:
            _break(lines, number, 0.0, s.decenter_mm, s.tilt_deg)
            number += 1
        curv = 0.0 if s.radius_mm is None else 1.0 / s.radius_mm
        _surface(lines, number, curv=curv, thickness=0.0 if tilted else s.thickness_mm)
        if s.conic:
            lines.append(f"  CONI {s.conic:.17E}")
        if s.material != "air":
            glass = MaterialFile(str(built.material(s.material).filename))
            nd, nf, nc = (float(np.ravel(glass.n(w))[0]) for w in (0.5875618, 0.4861327, 0.6562725))
            lines.append(f"  GLAS {s.material} 0 0 {nd:.6f} {(nd - 1) / (nf - nc):.4f} 0 0 0 0 0 0")
        if s.stop:
            lines.append("  STOP")
        if s.diameter_mm is not None:
            semi = s.diameter_mm / 2
            lines += [f'  DIAM {semi:.17E} 0 0 0 1 ""', f"  CLAP 0 {semi:.17E} 0"]
        number += 1
        if tilted:
            back = tuple(-a for a in s.tilt_deg)
            _break(lines, number, s.thickness_mm, tuple(-d for d in s.decenter_mm), back, order=1)
            number += 1
        origin, axes = running
        running = (origin + axes[:, 2] * s.thickness_mm, axes)
    _break(lines, number, 0.0, design.image_decenter_mm, design.image_tilt_deg)
    _surface(lines, number + 1)
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
