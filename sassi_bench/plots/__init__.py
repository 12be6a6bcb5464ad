"""Figures a scientist checks: calibration residuals, dispersion, blur, validation."""
