"""Reading a design from a Zemax file: the shipped achromat arm written as a .zmx traces
as its surfaces do, and files the design cannot reproduce are refused (needs the extra)."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from sassi_bench.errors import ConfigError
from sassi_bench.optics.design import OpticalDesign
from sassi_bench.optics.design.build import build_design
from sassi_bench.optics.design.zemax import design_mapping_from_file, read_zemax_design

pytest.importorskip("optiland", reason='the optiland ray tracer: pip install "sassi-bench[design]"')

ROOT = Path(__file__).resolve().parents[3]
# The shipped achromat arm as OpticStudio writes it (tests/optics/data/make_sim_achromat_zmx.py).
ZMX = ROOT / "tests" / "optics" / "data" / "sim-achromat.zmx"
SLM, CAMERA = (200, 320), (288, 512)
PITCHES = {"slm_pixel_pitch_um": 8.0, "camera_pixel_pitch_um": 5.5}


def _shipped() -> OpticalDesign:
    rig = yaml.safe_load((ROOT / "procedures" / "rigs" / "sim-achromat.yaml").read_text())
    return OpticalDesign.from_mapping(rig["design"])


def _chief_rays_um(design: OpticalDesign) -> np.ndarray:
    """Chief-ray landing points on the camera (um) over the SLM field and the band."""
    built = build_design(design, SLM, CAMERA)
    u, v = np.meshgrid(np.linspace(-10, 329, 5), np.linspace(-10, 209, 3))
    hx, hy = built.field_of(u.ravel(), v.ravel())
    zero = np.zeros_like(hx)
    points = []
    for nm in np.linspace(390.0, 720.0, 7):
        x, y, alive, _, _ = built.trace(hx, hy, zero, zero, float(nm))
        assert alive.all()
        points.append(np.stack([x, y], axis=-1) * design.camera_pixel_pitch_um)
    return np.array(points)


def test_the_achromat_file_traces_as_its_surfaces():
    from_file = read_zemax_design(ZMX, **PITCHES)
    shipped = _shipped()
    assert len(from_file.surfaces) == len(shipped.surfaces)
    assert from_file.dispersing_glass == "N-SF11"
    assert from_file.aperture == shipped.aperture
    assert from_file.image_tilt_deg == pytest.approx(shipped.image_tilt_deg)
    error = np.abs(_chief_rays_um(from_file) - _chief_rays_um(shipped)).max()
    assert error < 1.0  # um over the field and band (the bound); measured 2e-11 um


def test_optilands_own_converter_reads_the_file_alike():
    """An independent reading: optiland's converter (the file as an ``Optic``) lands the
    chief rays where the shipped surfaces do (its single-axis breaks are exact)."""
    from optiland.fileio import load_zemax_file

    built = build_design(_shipped(), SLM, CAMERA)
    optic = load_zemax_file(str(ZMX))
    optic.fields.set_type("object_height")
    optic.fields.add(y=built.max_field_mm, x=0.0)  # the file's one field is the axis
    optic.ray_tracer.set_aiming("iterative", max_iter=30, tol=1e-10)
    u, v = np.meshgrid(np.linspace(-10, 329, 5), np.linspace(-10, 209, 3))
    hx, hy = built.field_of(u.ravel(), v.ravel())
    zero = np.zeros_like(hx)
    frame = built.image_frame
    worst = 0.0
    for nm in np.linspace(390.0, 720.0, 7):
        rays = optic.trace_generic(hx, hy, zero, zero, nm * 1e-3)
        points = np.stack([np.asarray(rays.x), np.asarray(rays.y), np.asarray(rays.z)], -1)
        theirs = (points - frame.origin) @ frame.axes  # mm in the camera plane's axes
        x, y, _, _, _ = built.trace(hx, hy, zero, zero, float(nm))
        ours = np.stack([x - 0.5 * (CAMERA[1] - 1), y - 0.5 * (CAMERA[0] - 1)], -1) * 5.5e-3
        worst = max(worst, np.abs(theirs[:, :2] - ours).max(), np.abs(theirs[:, 2]).max())
    assert worst * 1e3 < 0.2  # um; measured 0.094 um


def _edited(tmp_path: Path, old: str, new: str) -> Path:
    text = ZMX.read_text()
    assert old in text
    path = tmp_path / "arm.zmx"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    ("old", "new", "cause"),
    [
        ("MODE SEQ", "MODE NSC", "not a sequential design"),
        ("UNIT MM", "UNIT IN", "millimetres"),
        ("GLAS N-SF11 0 0", "GLAS NOTAGLASS 0 0", "'NOTAGLASS' (surface 6) is not in"),
        ("GLAS N-SF11 0 0 1.784720", "GLAS N-SF11 0 0 1.700000", "nd 1.70000 in the file"),
        ("SURF 1\n  TYPE STANDARD", "SURF 1\n  TYPE EVENASPH", "type 'even_asphere'"),
        ("DISZ 2.13599999999999994E+01", "DISZ INFINITY", "object of arm.zmx is not a flat"),
        ("SURF 16\n  TYPE STANDARD\n  CURV 0.0", "SURF 16\n  TYPE STANDARD\n  CURV 0.01", "image"),
        ("GLAS SF10", "GLAS MIRROR", "mirror"),
        ("OBNA 4.00000000000000008E-02 0", "FLOA", "system aperture"),
        ("SURF 1\n", "SURF 1\n  SCBD 1 0 0 0.1 0 0 0 0\n", "its own tilt or decenter"),
        ("SURF 1\n", "SURF 1\n  SQAP 2 2 0 0\n", "rectangular aperture"),
        ("FTYP 1 0 1", "FTYP 1 1 1", "telecentric"),
        ("FTYP 1 0 1 1 0 0 0", "FTYP 1 0 1 1 0 0 1", "afocal image space"),
        ("MODE SEQ", "MODE SEQ\nMNUM 2 1", "2 configurations"),
        ("OBNA 4.00000000000000008E-02 0", "ENPD", "cannot read"),
    ],
)
def test_a_file_the_design_cannot_reproduce_is_refused(tmp_path, old, new, cause):
    with pytest.raises(ConfigError) as info:
        read_zemax_design(_edited(tmp_path, old, new), **PITCHES)
    message = str(info.value)
    assert message.startswith("rig description: design.file")
    assert cause in message
    assert "Fix:" in message


def test_a_relative_file_is_read_beside_the_rig(tmp_path):
    (tmp_path / ZMX.name).write_text(ZMX.read_text())
    mapping = design_mapping_from_file({"file": ZMX.name, **PITCHES}, tmp_path)
    assert mapping == read_zemax_design(ZMX, **PITCHES).to_mapping()
    with pytest.raises(ConfigError, match="does not exist"):
        design_mapping_from_file({"file": "lost.zmx", **PITCHES}, tmp_path)
    with pytest.raises(ConfigError, match=r"not taken beside design\.file"):
        design_mapping_from_file({"file": "arm.zmx", "surfaces": [], **PITCHES}, tmp_path)


def test_a_rig_gives_its_arm_as_a_file(tmp_path, monkeypatch):
    """A rig YAML beside its .zmx loads with the design the file means; the shipped
    achromat rig with its surfaces swapped for the file traces the same arm."""
    from sassi_bench.rig.config.loader import load_rig_description

    monkeypatch.setenv("SASSI_BENCH_DATA", str(tmp_path / "data"))
    monkeypatch.setenv("SASSI_BENCH_DESIGN_CACHE", str(tmp_path / "designs"))
    rig = yaml.safe_load((ROOT / "procedures" / "rigs" / "sim-achromat.yaml").read_text())
    rig["design"] = {"file": ZMX.name, **PITCHES}
    (tmp_path / ZMX.name).write_text(ZMX.read_text())
    (tmp_path / "arm-rig.yaml").write_text(yaml.safe_dump(rig))
    desc = load_rig_description(tmp_path / "arm-rig.yaml")
    assert desc.design == read_zemax_design(ZMX, **PITCHES)
    assert desc.prism.glass == "N-SF11"


def _break_params(values: list[float], order: int) -> str:
    return "".join(f"  PARM {k} {v!r}\n" for k, v in enumerate([*values, float(order)], 1))


def test_a_break_pair_around_a_surface_becomes_its_tilt_and_decenter(tmp_path):
    """OpticStudio's order 1 with every value negated undoes order 0 (decenter, then tilt
    about x, y, z): the pair around the prism's first face, tilted about three axes and
    decentred, is read as that face's own tilt_deg and decenter_mm."""
    text = ZMX.read_text()
    start = text.index("SURF 5\n")
    stop = text.index("SURF 8\n")
    block = text[start:stop]
    tilt, shift = [1.5, 27.6187, -2.0], [0.1, -0.2]
    before = block.split("  PARM 1")[0]
    face = block[block.index("SURF 6\n") : block.index("SURF 7\n")]
    after = block[block.index("SURF 7\n") :].split("  PARM 1")[0]
    new = (
        before
        + _break_params([*shift, *tilt], 0)
        + face
        + after
        + _break_params([-v for v in [*shift, *tilt]], 1)
    )
    path = tmp_path / "arm.zmx"
    path.write_text(text[:start] + new + text[stop:])
    face_read = read_zemax_design(path, **PITCHES).surfaces[4]
    assert face_read.material == "N-SF11"
    assert face_read.tilt_deg == pytest.approx(tilt, abs=1e-9)
    assert face_read.decenter_mm == pytest.approx(shift, abs=1e-12)
    assert face_read.thickness_mm == 8.0
    # the same pair written in the same order does not restore the axis: two breaks stay
    path.write_text(text[:start] + new.replace("  PARM 6 1.0\n", "  PARM 6 0.0\n") + text[stop:])
    entries = read_zemax_design(path, **PITCHES).surfaces
    assert len(entries) == 12 and entries[4].is_break and entries[6].is_break


def test_the_rig_hash_follows_the_files_bytes(tmp_path, monkeypatch):
    """The rig's identity holds the .zmx's SHA-256: the same file gives the same hash, one
    byte edited (a digit of a thickness, or a line the reader ignores) gives another; the
    traced grid's key follows the surfaces only."""
    import hashlib

    from sassi_bench.rig.config.loader import load_rig_description, rig_description_from_dict

    monkeypatch.setenv("SASSI_BENCH_DATA", str(tmp_path / "data"))
    rig = yaml.safe_load((ROOT / "procedures" / "rigs" / "sim-achromat.yaml").read_text())
    rig["design"] = {"file": "arm.zmx", **PITCHES}
    rig.pop("as_built", None)
    rig.pop("nuisance", None)
    (tmp_path / "arm-rig.yaml").write_text(yaml.safe_dump(rig))
    arm = tmp_path / "arm.zmx"
    raw = ZMX.read_bytes()

    def load(data: bytes):
        arm.write_bytes(data)
        return load_rig_description(tmp_path / "arm-rig.yaml")

    first = load(raw)
    assert first.design.file_sha256 == hashlib.sha256(raw).hexdigest()
    assert first.to_dict()["design"]["file_sha256"] == first.design.file_sha256
    assert load(raw).sha256() == first.sha256()
    # a digit of a thickness: other surfaces and another rig
    assert b"DISZ 2.13599999999999994E+01" in raw
    thicker = load(raw.replace(b"DISZ 2.13599999999999994E+01", b"DISZ 2.13699999999999994E+01"))
    assert thicker.design.sha256() != first.design.sha256()
    assert thicker.sha256() != first.sha256()
    # a byte in the file's title, which the design does not read: still another rig
    assert b"NAME sim-achromat" in raw
    retitled = load(raw.replace(b"NAME sim-achromat", b"NAME sim-achromaT"))
    assert retitled.design.sha256() == first.design.sha256()  # traces the same
    assert retitled.sha256() != first.sha256()
    # the description's dictionary form (what sessions store) loads back to the same rig
    again = rig_description_from_dict(first.to_dict())
    assert again.sha256() == first.sha256()
    assert again.design == first.design
