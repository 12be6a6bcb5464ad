"""The blur object (:class:`BlurModel`) and its forms, registered by name (:data:`BLUR_FORMS`)."""

from sassi_bench.bundle.blur.field_covariance import FieldCovarianceBlur
from sassi_bench.bundle.blur.model import (
    BLUR_FORMS,
    GAUSSIAN,
    BlurModel,
    GaussianProfile,
    Spot,
    blur_from_manifest,
)
from sassi_bench.bundle.blur.quadratic import QuadraticBlur

__all__ = [
    "BLUR_FORMS",
    "GAUSSIAN",
    "BlurModel",
    "FieldCovarianceBlur",
    "GaussianProfile",
    "QuadraticBlur",
    "Spot",
    "blur_from_manifest",
]
