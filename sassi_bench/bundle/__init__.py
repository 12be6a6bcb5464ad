"""Versioned, immutable, checksummed calibration bundles.

A bundle is a folder ``<data_root>/<rig>/<version>/`` holding ``manifest.json`` (schema
``sassi-bench/calibration-bundle``, validated by the JSON Schema shipped as
``manifest.schema.json``), ``manifest.sha256`` and ``arrays/*.npy`` (plus optional
``report/*``), every file checksummed. :func:`publish` writes one atomically and never
overwrites; :func:`load` returns a :class:`CalibrationBundle` only after the schema and every
checksum verify. The model contract (how the dispersion, bins and blur are evaluated) is
documented in :mod:`sassi_bench.bundle.models` (its field basis, also exported here, comes from
:mod:`sassi_bench.maths.legendre`); how far apart open SLM pixels must be
(:meth:`CalibrationBundle.mask_spacing`) in :mod:`sassi_bench.bundle.spacing`.

Examples
--------
>>> from sassi_bench.bundle import load
>>> bundle = load(rig="sim")
>>> x, y = bundle.slm_to_camera(320, 200, bundle.wavelengths)
"""

from sassi_bench.bundle.archive import ImportedBundle, export_zip, import_zip, verify_zip
from sassi_bench.bundle.blur import BlurModel, QuadraticBlur, Spot
from sassi_bench.bundle.bundle import CalibrationBundle, Streak
from sassi_bench.bundle.derive import publish_derived
from sassi_bench.bundle.diff import BundleDiff, diff_bundles, format_diff
from sassi_bench.bundle.errors import (
    BundleError,
    BundleIntegrityError,
    BundleQualityError,
    BundleSchemaError,
    BundleSchemaWarning,
    UnsafeArchiveError,
    UnsupportedSchemaError,
)
from sassi_bench.bundle.loader import load, verify
from sassi_bench.bundle.model_types import DispersionModel, WavelengthBins
from sassi_bench.bundle.models import CalibrationModels
from sassi_bench.bundle.quality import QualityCheck
from sassi_bench.bundle.schema import SCHEMA_NAME, SCHEMA_VERSION
from sassi_bench.bundle.spacing import MaskSpacing, mask_spacing
from sassi_bench.bundle.writer import publish
from sassi_bench.maths.legendre import legendre2d_design, legendre2d_terms

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "BlurModel",
    "BundleDiff",
    "BundleError",
    "BundleIntegrityError",
    "BundleQualityError",
    "BundleSchemaError",
    "BundleSchemaWarning",
    "CalibrationBundle",
    "CalibrationModels",
    "DispersionModel",
    "ImportedBundle",
    "MaskSpacing",
    "QuadraticBlur",
    "QualityCheck",
    "Spot",
    "Streak",
    "UnsafeArchiveError",
    "UnsupportedSchemaError",
    "WavelengthBins",
    "diff_bundles",
    "export_zip",
    "format_diff",
    "import_zip",
    "legendre2d_design",
    "legendre2d_terms",
    "load",
    "mask_spacing",
    "publish",
    "publish_derived",
    "verify",
    "verify_zip",
]
