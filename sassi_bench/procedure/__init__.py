"""Procedure files: the lab's editable parameters and acceptance tolerances, loaded and
checked against their schemas (``schemas/<procedure>.schema.json``)."""

from sassi_bench.procedure.files import (
    load_procedure,
    save_working_procedure,
    with_changes,
    working_procedure,
)

__all__ = ["load_procedure", "save_working_procedure", "with_changes", "working_procedure"]
