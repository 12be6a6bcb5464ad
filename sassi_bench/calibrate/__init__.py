"""Calibration fits: pure functions on arrays (no devices, no simulator internals)."""
