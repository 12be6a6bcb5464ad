"""Validation of a calibration: the Macbeth ColorChecker radiometric check and its report."""

from sassi_bench.validate.macbeth import MacbethResult, validate_macbeth
from sassi_bench.validate.reference import ReferenceChart, reference_chart

__all__ = ["MacbethResult", "ReferenceChart", "reference_chart", "validate_macbeth"]
