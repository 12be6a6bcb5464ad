"""Spectra from streaks: extraction with a calibration bundle, offset removal, cubes."""
