"""Acquisition: SLM patterns, capture plans, raw sessions on disk, and the plan runner.

This is the code that drives devices (plans, auto-exposure, snapshots); what a plan
captures goes to a session on disk (Zarr frames plus a JSON event log) so a capture can
be resumed and re-analysed.
"""
