"""Acquisition: SLM patterns, capture plans, raw sessions on disk, and the plan runner.

Plans are the only code that drives devices; everything they capture goes to a session
on disk (Zarr frames plus a JSON event log) so a capture can be resumed and re-analysed.
"""
