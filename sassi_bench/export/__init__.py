"""Exports of calibration bundles and captures for other reconstruction packages."""
