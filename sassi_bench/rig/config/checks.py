"""The checks a rig description passes when it is loaded, after its JSON Schema.

Physics (the SLM's image and its spectral streaks must fit on the spectral camera, the
lasers must lie on the spectral grid), consistency (a hardware section only on a hardware
rig, the virtual bench's own sections only on a virtual one) and the data sets the description
names (glass, lamps, guide sensor, QE curve, the virtual bench's chart and photo). Each
check raises :class:`~sassi_bench.errors.ConfigError` naming the key.
"""

from __future__ import annotations

import numpy as np

from sassi_bench.errors import ConfigError, did_you_mean, step_error
from sassi_bench.optics.datasets import photo_loader, require_dataset
from sassi_bench.optics.glass import Glass
from sassi_bench.optics.lamps import lamp_name, load_line_list
from sassi_bench.optics.psf import PsfSigmaCurve, line_spread_sigma
from sassi_bench.optics.relay import BAND_NM
from sassi_bench.optics.sensor import qe_curve
from sassi_bench.rig.cameras import hardware_camera_kinds
from sassi_bench.rig.config.description import RigDescription, rig_relative_path
from sassi_bench.rig.lights import light_kinds

__all__ = ["check_description"]


def _error(desc: RigDescription, key: str, cause: str, fix: str) -> ConfigError:
    """A :class:`ConfigError` naming the description and the key."""
    return ConfigError(
        step_error(f"rig description {desc.source or desc.name}", f"{key}: {cause}", fix)
    )


def _check_backend(desc: RigDescription) -> None:
    if desc.backend == "hardware" and desc.hardware is None:
        raise _error(
            desc,
            "hardware",
            "backend 'hardware' needs a hardware section",
            "add one (see procedures/rigs/lab-example.yaml)",
        )
    if desc.backend != "hardware" and desc.hardware is not None:
        raise _error(
            desc,
            "hardware",
            f"only read with backend 'hardware' (this rig's backend is {desc.backend!r})",
            "remove the section or change the backend",
        )
    for camera in ("spectral_camera", "guide_camera"):
        kind = ((desc.hardware or {}).get(camera) or {}).get("kind")
        if kind is not None and kind not in (kinds := hardware_camera_kinds()):
            raise _error(
                desc,
                f"hardware.{camera}.kind",
                f"unknown camera kind {kind!r}{did_you_mean(kind, kinds)}",
                f"use one of {', '.join(kinds)}",
            )


def _check_bench_sections(desc: RigDescription) -> None:
    """Sections beyond the description are read by the virtual bench alone (their content
    is checked there, by :mod:`sassi_bench.rig.sim.sections`)."""
    given = sorted(key for key, section in desc.bench_sections.items() if section)
    if desc.backend != "sim" and given:
        raise _error(
            desc,
            given[0],
            f"only read by the virtual bench (this rig's backend is {desc.backend!r})",
            "remove the section: a real bench is as built already",
        )


def _check_ranges(desc: RigDescription) -> None:
    grid = desc.spectral_grid
    if grid.stop_nm - grid.start_nm < 10:
        raise _error(
            desc, "spectral_grid", "stop_nm must exceed start_nm by at least 10 nm", "widen it"
        )
    if grid.start_nm > 400 or grid.stop_nm < 700:
        raise _error(
            desc,
            "spectral_grid",
            f"{grid.start_nm:g}-{grid.stop_nm:g} nm does not cover the calibrated band, 400-700 nm",
            "set start_nm <= 400 and stop_nm >= 700",
        )
    outside = [x for x in desc.lasers_nm if not grid.start_nm <= x <= grid.stop_nm]
    if outside:
        raise _error(
            desc,
            "lasers_nm",
            f"{', '.join(f'{x:g}' for x in outside)} nm lie outside the spectral grid "
            f"{grid.start_nm:g}-{grid.stop_nm:g} nm",
            "remove them or widen spectral_grid",
        )
    for key, rng in (
        ("spectral_camera.exposure_range_s", desc.spectral_camera.exposure_range_s),
        ("guide_camera.exposure_range_s", desc.guide_camera.exposure_range_s),
    ):
        if not 0 < rng[0] < rng[1]:
            raise _error(desc, key, f"got {list(rng)}", "give [min, max] with 0 < min < max")
    if desc.guide_camera.homography is not None:
        h = np.asarray(desc.guide_camera.homography, dtype=float)
        if abs(np.linalg.det(h)) < 1e-12:
            raise _error(
                desc, "guide_camera.homography", "the matrix is singular", "give an invertible 3x3"
            )
    cam = desc.spectral_camera
    if cam.dark_offset_adu >= 2**cam.bit_depth - 1:
        raise _error(
            desc,
            "spectral_camera.dark_offset_adu",
            f"{cam.dark_offset_adu:g} ADU is not below the {cam.bit_depth}-bit ADC range",
            "give the camera's black level in ADU",
        )


def _check_sellmeier(desc: RigDescription, glass: Glass) -> None:
    """A rig's own glass: a real optical glass's index over 400-700 nm (finite, 1.3-2.5,
    falling with wavelength)."""
    index = glass.index(np.linspace(400.0, 700.0, 31))
    if not np.all(np.isfinite(index)):
        cause = "the coefficients give no real index at some wavelengths of 400-700 nm"
    elif np.any((index <= 1.3) | (index >= 2.5)) or np.any(np.diff(index) >= 0):
        cause = (
            f"the coefficients give an index of {index.min():.3g}-{index.max():.3g} over "
            "400-700 nm, not that of an optical glass (1.3-2.5, falling with wavelength)"
        )
    else:
        return
    raise _error(
        desc,
        "prism.sellmeier",
        cause,
        "copy B1-B3 and C1-C3 (C in square micrometres) from the glass maker's data sheet",
    )


def _check_named_data(desc: RigDescription) -> None:
    """Every glass, lamp, sensor and curve the description names must exist (a glass the
    catalogue lacks needs its Sellmeier coefficients, which must give a plausible index)."""
    glass = desc.prism.glass_model()  # an unknown catalogue name raises here
    if desc.prism.sellmeier is not None:
        _check_sellmeier(desc, glass)
    if desc.spectral_camera.qe is not None:
        qe_curve(desc.spectral_camera.qe, key="spectral_camera.qe")
    if desc.guide_camera.sensitivities is not None:
        require_dataset("camera", desc.guide_camera.sensitivities, "guide_camera.sensitivities")
    for kind in light_kinds():  # the data sets each kind of light names
        kind.check(desc)
    if desc.backend == "sim":  # the scenes are the virtual bench's
        require_dataset("colourchecker", desc.scenes.colorchecker_data, "scenes.colorchecker_data")
        photo_loader(desc.scenes.natural_image)


def _check_lasers_and_lamps(desc: RigDescription) -> None:
    """Every wavelength lamp's table loads and has anchor lines in the band, lamp names are
    distinct, and ``laser_tolerance_nm`` names lasers of the rig."""
    step = f"rig description {desc.source or desc.name}"
    base = rig_relative_path(desc, ".")
    names: dict[str, str] = {}
    for entry in desc.wavelength_lamps:
        name = lamp_name(entry, f"{step}: wavelength_lamps")
        if name in names:
            raise _error(
                desc,
                "wavelength_lamps",
                f"{names[name]!r} and {entry!r} are both lamp {name!r}",
                "list each lamp once (a CSV's lamp is named by its file name)",
            )
        names[name] = entry
        load_line_list(entry, base=base, step=f"{step}: wavelength_lamps")
    if isinstance(desc.laser_tolerance_nm, dict):
        unknown = sorted(set(desc.laser_tolerance_nm) - set(desc.lasers_nm))
        if unknown:
            labels = [f"{x:g}" for x in desc.lasers_nm]
            raise _error(
                desc,
                "laser_tolerance_nm",
                f"{unknown[0]:g} nm is not a line of lasers_nm "
                f"({', '.join(labels)}){did_you_mean(f'{unknown[0]:g}', labels)}",
                "key each tolerance by the laser's label",
            )


def _check_streaks_fit(desc: RigDescription) -> None:
    """The SLM's image with its 400-700 nm streaks (and 3 sigma of blur) must lie on the
    spectral camera, by the description's nominal optics (a ray trace through the prism)."""
    band = np.array(BAND_NM)
    blur = PsfSigmaCurve(desc.blur.sigma_px)(band)
    h, w = desc.slm.height, desc.slm.width
    hc, wc = desc.spectral_camera.height, desc.spectral_camera.width
    relay = desc.nominal_relay()
    u = np.array([0.0, w - 1, 0.0, w - 1])[:, None]
    v = np.array([0.0, 0.0, h - 1, h - 1])[:, None]
    x, y = relay.forward(u, v, band[None, :])
    reach = 3.0 * float(line_spread_sigma(blur, desc.relay.scale, desc.slm.fill_factor).max())
    x0, x1, y0, y1 = x.min() - reach, x.max() + reach, y.min() - reach, y.max() + reach
    if not np.all(np.isfinite(x)) or x0 < 0 or x1 > wc - 1 or y0 < 0 or y1 > hc - 1:
        raise _error(
            desc,
            "relay",
            f"the SLM's image with its 400-700 nm streaks spans camera x {x0:.0f}..{x1:.0f}, "
            f"y {y0:.0f}..{y1:.0f}, outside the {wc}x{hc} camera",
            "lower relay.scale or prism.spread_px, or move relay.offset_px",
        )


#: The checks a description passes after its schema, in order.
_CHECKS = (
    _check_backend,
    _check_bench_sections,
    _check_ranges,
    _check_named_data,
    _check_lasers_and_lamps,
    _check_streaks_fit,
)


def check_description(desc: RigDescription) -> None:
    """Run every load-time check on a built description, in order.

    Parameters
    ----------
    desc
        The description built from a mapping that passed the JSON Schema.

    Raises
    ------
    ConfigError
        From the first check that fails, naming the key.

    Examples
    --------
    >>> import dataclasses
    >>> from sassi_bench.rig.config import load_rig_description
    >>> desc = load_rig_description("sim")
    >>> check_description(desc)
    >>> check_description(dataclasses.replace(desc, hardware={"slm": {}}))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: rig description ...: hardware: only read with backend ...
    """
    for check in _CHECKS:
        check(desc)
