"""Workflows: procedures that drive a rig, run the fits and publish bundles.

A workflow reads a procedure YAML (``procedures/*.yaml``), captures into raw sessions
through :mod:`sassi_bench.acquire`, fits with :mod:`sassi_bench.calibrate` and publishes
with :mod:`sassi_bench.bundle`. Workflows use device handles only, nothing of a
virtual bench's internals.
"""
