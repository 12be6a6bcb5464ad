"""The virtual bench as built: the true values behind a rig's nominal description.

A lab knows its bench by nominal values: laser lines by their labels, the prism by its
catalogue glass and drawing, the halogen lamp by its rated colour temperature, the guide
camera by its data sheet. A rig's ``as_built`` section (read here and nowhere outside
``rig/sim``) says how the virtual bench really differs; every function below returns the
true value, and the nominal one when the section leaves the key out. Procedures never
see any of this: they are told the description only, and the bench renders the truth.

Examples
--------
>>> from sassi_bench.rig.config import load_rig_description
>>> desc = load_rig_description("sim")  # no as_built section: everything as described
>>> laser_centre_nm(desc, 635.0), halogen_k(desc), slm_gamma(desc)
(635.0, 3000.0, 2.2)
"""

from __future__ import annotations

import dataclasses
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.optics.datasets import camera_sensitivities
from sassi_bench.optics.glass import Glass
from sassi_bench.optics.lamps import LineList
from sassi_bench.rig.config import RigDescription, rig_relative_path
from sassi_bench.rig.sim.sections import as_built_section

__all__ = [
    "OffsetGlass",
    "guide_sensitivities",
    "halogen_k",
    "lamp_lines",
    "laser_centre_nm",
    "led",
    "light_settings",
    "prism_apex_deg",
    "prism_glass",
    "slm_gamma",
]


@dataclass(frozen=True)
class OffsetGlass(Glass):
    """A catalogue glass whose melt's index is off by a constant at every wavelength.

    Examples
    --------
    >>> from sassi_bench.optics.glass import get_glass
    >>> bk7 = get_glass("N-BK7")
    >>> melt = OffsetGlass(bk7.name, bk7.b, bk7.c, bk7.nd, bk7.vd, index_offset=0.002)
    >>> round(float(melt.index(587.5618) - bk7.index(587.5618)), 6)
    0.002
    """

    index_offset: float = 0.0

    def index(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Refractive index at ``wavelength_nm``: the catalogue's plus the offset."""
        return super().index(wavelength_nm) + self.index_offset


def laser_centre_nm(desc: RigDescription, nominal_nm: float) -> float:
    """True centre (nm) of the laser line labelled ``nominal_nm``.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> laser_centre_nm(load_rig_description("sim"), 532.0)
    532.0
    """
    return float(as_built_section(desc).lasers_nm.get(float(nominal_nm), nominal_nm))


def lamp_lines(desc: RigDescription, name: str) -> LineList:
    """The true lines of wavelength lamp ``name``: its table's wavelengths, with each line's
    intensity off the table by a log-normal factor of ``as_built.lamp_intensity_spread``
    (drawn once per rig seed and lamp; the table's own intensities without it).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> lines = lamp_lines(load_rig_description("sim"), "HgAr")
    >>> float(lines.relative_intensity.max())
    1.0
    """
    lines = desc.lamp_lines()[name]
    spread = as_built_section(desc).lamp_intensity_spread
    if spread == 0.0:
        return lines
    seed = np.random.SeedSequence([desc.seed, 14, zlib.crc32(name.encode())])
    factor = np.exp(spread * np.random.default_rng(seed).standard_normal(lines.wavelengths_nm.size))
    return dataclasses.replace(lines, relative_intensity=lines.relative_intensity * factor)


def prism_glass(desc: RigDescription) -> Glass:
    """The prism's true glass: the catalogue glass plus ``as_built.glass_index_offset``.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> prism_glass(load_rig_description("sim")).name
    'N-BK7'
    """
    catalogue = desc.prism.glass_model()
    offset = as_built_section(desc).glass_index_offset
    if offset == 0.0:
        return catalogue
    return OffsetGlass(catalogue.name, catalogue.b, catalogue.c, catalogue.nd, catalogue.vd, offset)


def prism_apex_deg(desc: RigDescription) -> float:
    """The prism's true apex angle (degrees).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> prism_apex_deg(load_rig_description("sim"))
    30.0
    """
    true = as_built_section(desc).apex_deg
    return float(true if true is not None else desc.prism.apex_deg)


def halogen_k(desc: RigDescription) -> float:
    """The halogen lamp's true colour temperature (K).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> halogen_k(load_rig_description("sim"))
    3000.0
    """
    true = as_built_section(desc).halogen_k
    return float(true if true is not None else desc.light.halogen_k)


def led(desc: RigDescription) -> str:
    """The colour-science illuminant that is the LED's true spectrum.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> led(load_rig_description("sim"))
    'LED-B3'
    """
    true = as_built_section(desc).led
    return true if true is not None else desc.light.led


def light_settings(
    desc: RigDescription, light: str, described: Mapping[str, Any]
) -> dict[str, Any]:
    """A light's settings as built (its kind's :meth:`~sassi_bench.rig.lights.LightKind.settings`
    as described, with the bench's deviations): a laser's true centre, the LED's true
    spectrum, the halogen lamp's true temperature, a lamp's lines at their true
    intensities; any other setting as described.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> light_settings(load_rig_description("sim"), "laser:532", {"centre_nm": 532.0})
    {'centre_nm': 532.0}
    """
    true = _AS_BUILT_LIGHTS.get(light.split(":")[0])
    return dict(described) if true is None else {**described, **true(desc, light, described)}


def _laser_width(desc: RigDescription) -> dict[str, float]:
    """The lasers' true line width, where the bench is built with another than described."""
    true = as_built_section(desc).laser_fwhm_nm
    return {} if true is None else {"fwhm_nm": float(true)}


#: The as-built settings of each kind of light (by the lights' name prefix).
_AS_BUILT_LIGHTS = {
    "laser": lambda desc, light, s: {
        "centre_nm": laser_centre_nm(desc, s["centre_nm"]),
        **_laser_width(desc),
    },
    "led": lambda desc, light, s: {"illuminant": led(desc)},
    "halogen": lambda desc, light, s: {"temperature_k": halogen_k(desc)},
    "lamp": lambda desc, light, s: {"lines": lamp_lines(desc, light[5:])},
}


def slm_gamma(desc: RigDescription) -> float:
    """The SLM's true grey-level exponent.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> slm_gamma(load_rig_description("sim"))
    2.2
    """
    true = as_built_section(desc).slm_gamma
    return float(true if true is not None else desc.slm.gamma)


def guide_sensitivities(desc: RigDescription, wavelengths_nm: ArrayLike) -> NDArray[np.float64]:
    """The guide camera's true RGB curves (3, L) at ``wavelengths_nm``, peak 1.

    ``as_built.guide_sensitivities`` names a colour-science camera or a CSV of
    ``wavelength_nm,r,g,b`` (relative to the rig YAML); left out, the described sensor.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> guide_sensitivities(load_rig_description("sim"), [450.0, 550.0, 650.0]).shape
    (3, 3)
    """
    name = as_built_section(desc).guide_sensitivities
    if name is None:
        return camera_sensitivities(desc.guide_camera.sensitivities, wavelengths_nm)
    if not name.lower().endswith(".csv"):
        return camera_sensitivities(name, wavelengths_nm, "as_built.guide_sensitivities")
    return _csv_sensitivities(rig_relative_path(desc, name), wavelengths_nm)


def _csv_sensitivities(path, wavelengths_nm: ArrayLike) -> NDArray[np.float64]:
    """RGB curves from a ``wavelength_nm,r,g,b`` CSV (one header line), peak 1."""
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise ConfigError(
            step_error(
                "as_built.guide_sensitivities",
                f"{path} is not a CSV of numbers ({exc})",
                "write one header line, then rows of wavelength_nm,r,g,b",
            )
        ) from exc
    if table.shape[1] != 4 or table.shape[0] < 2 or np.any(np.diff(table[:, 0]) <= 0):
        raise ConfigError(
            step_error(
                "as_built.guide_sensitivities",
                f"{path} needs four columns and increasing wavelengths",
                "write rows of wavelength_nm,r,g,b sorted by wavelength",
            )
        )
    grid = np.asarray(wavelengths_nm, dtype=np.float64)
    curves = np.stack(
        [np.interp(grid, table[:, 0], table[:, c], left=0.0, right=0.0) for c in (1, 2, 3)]
    )
    return curves / curves.max()


def blur_sigma_px(desc: RigDescription) -> dict[float, float]:
    """The optics' true PSF sigma points: the described curve, moved along the
    wavelength axis by ``as_built.focus_shift_nm`` (a camera at the best focus of
    another wavelength).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> blur_sigma_px(load_rig_description("sim"))
    {405.0: 1.7, 520.0: 0.42, 635.0: 1.7}
    """
    shift = as_built_section(desc).focus_shift_nm
    return {float(nm) + shift: float(sigma) for nm, sigma in desc.blur.sigma_px.items()}
