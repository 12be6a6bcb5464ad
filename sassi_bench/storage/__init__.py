"""What the workbench keeps on disk under the data root, how big it is, and cleaning it.

:func:`~sassi_bench.storage.inventory.inventory` lists the raw sessions, staging folders,
published bundles and reports with their sizes, ages and which bundle uses which
session as an input; :func:`~sassi_bench.storage.clean.clean_candidates` picks what can be
removed without touching a published bundle (``sassi-bench data list|clean``).
"""
