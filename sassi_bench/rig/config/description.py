"""What a rig description holds: one frozen dataclass per section, and the whole description.

Built and checked by :func:`~sassi_bench.rig.config.load_rig_description`; the sections
only a virtual bench reads stay raw in :attr:`RigDescription.bench_sections`.

Examples
--------
>>> from sassi_bench.rig.config import load_rig_description
>>> load_rig_description("sim").light_names[-1]
'lamp:Ne'
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sassi_bench._shared.canonical_json import canonical_sha256
from sassi_bench.optics.design import OpticalDesign, design_relay
from sassi_bench.optics.design.relay import DesignRelay
from sassi_bench.optics.glass import Glass, get_glass
from sassi_bench.optics.lamps import LineList, load_line_list
from sassi_bench.optics.psf import PsfSigmaCurve
from sassi_bench.optics.relay import SpectralRelay
from sassi_bench.rig.lights import light_names

__all__ = [
    "DEFAULT_LASER_TOLERANCE_NM",
    "BlurConfig",
    "GuideCameraConfig",
    "LightConfig",
    "PrismConfig",
    "RelayConfig",
    "RigDescription",
    "ScenesConfig",
    "SellmeierConfig",
    "SlmConfig",
    "SpectralCameraConfig",
    "SpectralGridConfig",
    "rig_dict_sha256",
    "rig_relative_path",
]

#: How far a laser's true line may be from its label, nm: a catalogue diode module's
#: data sheet tolerance (a rig's ``laser_tolerance_nm`` overrides it).
DEFAULT_LASER_TOLERANCE_NM = 5.0


@dataclass(frozen=True)
class SlmConfig:
    width: int
    height: int
    contrast_ratio: float
    gamma: float = 2.2
    fill_factor: float = 0.93


@dataclass(frozen=True)
class SpectralCameraConfig:
    width: int
    height: int
    read_noise_e: float
    full_well_e: float
    bit_depth: int
    dark_offset_adu: float = 100.0
    dark_current_e_per_s: float = 0.5
    qe: str | dict[str, float] | None = None
    exposure_range_s: tuple[float, float] = (1e-5, 10.0)


@dataclass(frozen=True)
class RelayConfig:
    scale: float
    rotation_deg: float
    offset_px: tuple[float, float]
    distortion_k1: float


@dataclass(frozen=True)
class SellmeierConfig:
    """A glass's three-term Sellmeier coefficients (``C`` in µm²), from its data sheet."""

    b: tuple[float, float, float]
    c: tuple[float, float, float]


@dataclass(frozen=True)
class PrismConfig:
    glass: str
    apex_deg: float
    spread_px: float
    smile_px: float
    incidence_deg: float | None = None
    reference_nm: float = 550.0
    #: The glass's own coefficients; None: the catalogue glass named ``glass``.
    sellmeier: SellmeierConfig | None = None

    def glass_model(self) -> Glass:
        """The prism glass: the rig's own Sellmeier coefficients when given, else the
        catalogue glass of that name.

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> load_rig_description("sim").prism.glass_model().name
        'N-BK7'
        """
        if self.sellmeier is None:
            return get_glass(self.glass)
        return Glass.from_sellmeier(self.glass, self.sellmeier.b, self.sellmeier.c)


@dataclass(frozen=True)
class BlurConfig:
    sigma_px: dict[float, float]


@dataclass(frozen=True)
class GuideCameraConfig:
    width: int
    height: int
    scale: float = 1.0
    rotation_deg: float = 0.0
    offset_px: tuple[float, float] = (0.0, 0.0)
    homography: tuple[tuple[float, ...], ...] | None = None
    read_noise_e: float = 3.0
    full_well_e: float = 10000.0
    bit_depth: int = 12
    sensitivities: str | None = None
    blur_px: float = 0.6
    exposure_range_s: tuple[float, float] = (1e-5, 10.0)


@dataclass(frozen=True)
class LightConfig:
    laser_fwhm_nm: float = 1.0
    laser_flux: float = 2.0e6
    broadband_flux: float = 2.0e7
    led: str | None = None
    halogen_k: float | None = None
    fluorescent: str | None = None


@dataclass(frozen=True)
class SpectralGridConfig:
    start_nm: float = 390.0
    stop_nm: float = 720.0
    step_nm: float = 2.0


@dataclass(frozen=True)
class ScenesConfig:
    margin_px: int = 48
    colorchecker_data: str = "BabelColor Average"
    colorchecker_rotation_deg: float = 1.5
    natural_image: str = "coffee"


@dataclass(frozen=True)
class RigDescription:
    """A validated rig description (all defaults filled in).

    Use :func:`~sassi_bench.rig.config.load_rig_description` to build one from YAML and
    :meth:`to_dict` for the canonical JSON-compatible form stored in calibration bundles.
    """

    name: str
    backend: str
    slm: SlmConfig
    spectral_camera: SpectralCameraConfig
    relay: RelayConfig
    prism: PrismConfig
    blur: BlurConfig
    guide_camera: GuideCameraConfig
    lasers_nm: tuple[float, ...]
    seed: int = 0
    description: str = ""
    light: LightConfig = field(default_factory=LightConfig)
    spectral_grid: SpectralGridConfig = field(default_factory=SpectralGridConfig)
    scenes: ScenesConfig = field(default_factory=ScenesConfig)
    hardware: dict[str, Any] | None = None
    #: Gas-discharge lamps whose lines anchor the wavelength axis: shipped lamp names
    #: (``HgAr``, ``Ne``) or paths of CSV line tables (relative to the rig YAML).
    wavelength_lamps: tuple[str, ...] = ()
    #: How far each laser's true line may be from its label (nm): one number for every
    #: line, or per label (a DPSS 532 nm line is exact); None: 5 nm for every line.
    laser_tolerance_nm: float | dict[float, float] | None = None
    source: str | None = None
    #: The spectral arm as an optical design (``design:``), or None: the parametric
    #: ``relay``, ``prism`` and ``blur`` sections describe it. With a design those three
    #: sections are derived from it (:func:`~sassi_bench.optics.design.nominal_summary`)
    #: and left out of :meth:`to_dict`.
    design: OpticalDesign | None = None
    #: Sections the schema accepts beyond the description, kept raw for the virtual bench
    #: (parsed by :mod:`sassi_bench.rig.sim.sections`): not part of what procedures rely
    #: on, the dictionary form or the hash.
    bench_sections: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def light_names(self) -> tuple[str, ...]:
        """The names of the rig's lights: ``off``, ``laser:<nm>`` per line, ``led``,
        ``halogen``, ``fluorescent`` and ``lamp:<name>`` per wavelength lamp
        (:mod:`sassi_bench.rig.lights`).

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> load_rig_description("sim").light_names[:3]
        ('off', 'laser:450', 'laser:520')
        """
        return light_names(self.lasers_nm, self.wavelength_lamps)

    def lamp_lines(self) -> dict[str, LineList]:
        """The line list of every wavelength lamp, by lamp name.

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> sorted(load_rig_description("sim").lamp_lines())
        ['HgAr', 'Ne']
        """
        base = rig_relative_path(self, ".")
        lists = [load_line_list(entry, base=base) for entry in self.wavelength_lamps]
        return {lines.name: lines for lines in lists}

    def laser_tolerance(self, label_nm: float) -> float:
        """How far the true line of the laser labelled ``label_nm`` may be off its label (nm).

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> load_rig_description("sim").laser_tolerance(532.0)
        5.0
        """
        given = self.laser_tolerance_nm
        if isinstance(given, dict):
            return float(given.get(float(label_nm), DEFAULT_LASER_TOLERANCE_NM))
        return float(given) if given is not None else DEFAULT_LASER_TOLERANCE_NM

    def to_dict(self) -> dict[str, Any]:
        """Canonical JSON-compatible form (the ``source`` path and the bench-only
        sections are left out; so are unset optional keys, so a rig without lamps keeps
        the hash it had before lamps existed)."""
        data = asdict(self)
        for key in ("source", "bench_sections"):
            data.pop(key)
        if self.design is None:
            data.pop("design")
        else:  # the design is the description; relay, prism and blur follow from it
            data["design"] = self.design.to_mapping()
            for key in ("relay", "prism", "blur"):
                data.pop(key)
        for key in ("hardware", "laser_tolerance_nm"):
            if data[key] is None:
                data.pop(key)
        if not data["wavelength_lamps"]:
            data.pop("wavelength_lamps")
        if "prism" in data and data["prism"]["sellmeier"] is None:
            data["prism"].pop("sellmeier")  # a catalogue glass: as before the key existed
        return json.loads(json.dumps(data, sort_keys=True))

    def sha256(self) -> str:
        """SHA-256 of the canonical JSON form; identifies the rig in bundles.

        Where hardware is plugged in (serial port, monitor, producer or library path,
        timeouts) is left out: moving a cable does not make another rig.
        """
        return rig_dict_sha256(self.to_dict())

    def nominal_relay(self) -> SpectralRelay | DesignRelay:
        """The SLM -> spectral camera optics as described: a ray trace of the relay and prism.

        This is the one seam through which procedures (capture plans and their checks)
        see the described optics. It returns a
        :class:`~sassi_bench.optics.relay.SpectralRelay` for a parametric rig and a
        :class:`~sassi_bench.optics.design.relay.DesignRelay` (the described ``design:``
        traced by optiland, read through interpolants, as described) for a design
        rig. Both answer ``forward(u, v, wavelength)``,
        ``forward_grid``, ``inverse``, ``scale``, ``slm_shape``, ``camera_shape`` and
        ``reference_nm``; :meth:`nominal_psf` gives the described spot width.

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> relay = load_rig_description("sim").nominal_relay()
        >>> x, _ = relay.forward(319.5, 199.5, [400.0, 700.0])
        >>> round(float(x[1] - x[0]), 6)  # prism.spread_px
        68.0
        """
        if self.design is not None:
            return design_relay(
                self.design,
                (self.slm.height, self.slm.width),
                (self.spectral_camera.height, self.spectral_camera.width),
                (self.spectral_grid.start_nm, self.spectral_grid.stop_nm),
            )
        relay, prism = self.relay, self.prism
        return SpectralRelay(
            (self.slm.height, self.slm.width),
            (self.spectral_camera.height, self.spectral_camera.width),
            scale=relay.scale,
            rotation_deg=relay.rotation_deg,
            offset_px=relay.offset_px,
            distortion_k1=relay.distortion_k1,
            glass=prism.glass_model(),
            apex_deg=prism.apex_deg,
            spread_px=prism.spread_px,
            smile_px=prism.smile_px,
            incidence_deg=prism.incidence_deg,
            reference_nm=prism.reference_nm,
        )

    def nominal_optic(self) -> Any:
        """The described design as an optiland optic (for drawing its layout); None for a
        parametric rig. Needs the ``design`` extra."""
        if self.design is None:
            return None
        from sassi_bench.optics.design.build import build_design

        shapes = (
            (self.slm.height, self.slm.width),
            (self.spectral_camera.height, self.spectral_camera.width),
        )
        return build_design(self.design, *shapes).optic

    def nominal_psf(self) -> PsfSigmaCurve:
        """The optics' point-spread sigma over wavelength as described (camera px).

        For a design rig, the widest spot over the SLM at each wavelength (what
        footprints and spacing must reserve), from the described design's trace.

        Examples
        --------
        >>> from sassi_bench.rig.config import load_rig_description
        >>> round(float(load_rig_description("sim").nominal_psf()(550.0)), 3)
        0.507
        """
        return PsfSigmaCurve(self.blur.sigma_px)


_CONNECTION_KEYS = {"port", "baudrate", "timeout_s", "boot_s", "monitor", "cti", "library"}


def _without_connection(hardware: dict[str, Any]) -> dict[str, Any]:
    return {
        device: {k: v for k, v in spec.items() if k not in _CONNECTION_KEYS}
        for device, spec in hardware.items()
    }


def rig_dict_sha256(data: dict[str, Any]) -> str:
    """The SHA-256 that identifies a rig, from its canonical form (:meth:`RigDescription.to_dict`,
    as sessions and bundles store it): where hardware is plugged in is left out.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> lab = load_rig_description("lab-example")
    >>> rig_dict_sha256(lab.to_dict()) == lab.sha256()
    True
    """
    if "hardware" in data:
        data = {**data, "hardware": _without_connection(data["hardware"])}
    return canonical_sha256(data)


def rig_relative_path(desc: RigDescription, name: str) -> Path:
    """A file a rig key names (a lamp's lines, the virtual bench's guide curves), relative
    to the rig YAML's folder.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> rig_relative_path(load_rig_description("sim"), "/abs/lines.csv").as_posix()
    '/abs/lines.csv'
    """
    path = Path(name)
    if not path.is_absolute() and desc.source is not None and Path(desc.source).is_file():
        path = Path(desc.source).parent / path
    return path
