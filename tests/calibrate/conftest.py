"""Fixtures shared by the calibration tests."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.calibrate.anchored import LampStreaks
from sassi_bench.calibrate.lamp_streaks import StreakProfiles
from sassi_bench.optics.lamps import load_line_list


def _lamp_streaks(name, column, sigma_px, rng, *, amplitude_spread=0.0, signal=20000.0):
    """One lamp's pinhole streaks on a 64 x 48 SLM: 15 pinholes, every listed line of
    395-715 nm a Gaussian spot of ``sigma_px(λ)`` where ``column(u, v, λ)`` puts it, the
    table's intensities (each scaled by up to ``amplitude_spread`` either way, as one
    lamp emits them), ``signal`` e- at the brightest, photon and 5 e- read noise."""
    lines = load_line_list(name)
    keep = (lines.wavelengths_nm > 395.0) & (lines.wavelengths_nm < 715.0)
    lam, table = lines.wavelengths_nm[keep], lines.relative_intensity[keep]
    u, v = (x.ravel() for x in np.meshgrid(np.linspace(4, 60, 5), np.linspace(4, 44, 3)))
    start = np.floor(column(u, v, 395.0)) - 12
    columns = start[:, None] + np.arange(int(column(0, 0, 715.0) - column(0, 0, 395.0)) + 24)
    true = column(u[:, None], v[:, None], lam[None, :])  # (P, K)
    amplitude = table
    if amplitude_spread:
        amplitude = table * rng.uniform(1 - amplitude_spread, 1 + amplitude_spread, lam.size)
    spots = np.exp(-0.5 * ((columns[:, :, None] - true[:, None, :]) / sigma_px(lam)) ** 2)
    clean = signal * spots @ (amplitude / amplitude.max())
    variance = clean + 25.0
    profile = clean + rng.normal(size=clean.shape) * np.sqrt(variance)
    profiles = StreakProfiles(
        f"lamp:{name}", u, v, columns.astype(float), profile, variance,
        np.zeros((u.size, 2), dtype=np.intp),
    )  # fmt: skip
    return LampStreaks(name, lam, table, sigma_px(lam), aperture_px=0.1, profiles=profiles)


@pytest.fixture(scope="session")
def synthetic_lamp_streaks():
    """A builder of one lamp's noisy pinhole streaks on a small synthetic arm:
    ``build(name, column, sigma_px, rng, amplitude_spread=0.0, signal=20000.0)``."""
    return _lamp_streaks
