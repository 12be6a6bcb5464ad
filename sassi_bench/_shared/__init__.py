"""Plumbing every layer may use: atomic file writes, canonical JSON, YAML loading, array
argument checks, advisory locks that name their holder, and table rendering.

Nothing here knows of rigs, bundles or procedures; every module depends on the standard
library, NumPy and :mod:`sassi_bench.errors` only (see the layer table in
``docs/ARCHITECTURE.md``).
"""
