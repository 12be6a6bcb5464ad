"""Shared fixtures: a synthetic bundle (tests/bundle/conftest.py's models) and odd spacings."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.bundle import MaskSpacing, load

_spec = importlib.util.spec_from_file_location(
    "bundle_synthetic", Path(__file__).parents[1] / "bundle" / "conftest.py"
)
synthetic_models = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = synthetic_models
_spec.loader.exec_module(synthetic_models)


@pytest.fixture(scope="session")
def synthetic_bundle(tmp_path_factory):
    """The synthetic prototype-like bundle of the bundle tests (640 x 400 SLM, with a guide
    homography and a response)."""
    return load(synthetic_models.publish_synthetic(tmp_path_factory.mktemp("snapshot-bundle")))


@pytest.fixture(scope="session")
def synthetic_spacing(synthetic_bundle):
    return synthetic_bundle.mask_spacing()


def pairs_in_conflict(mask: np.ndarray, spacing: MaskSpacing) -> list[tuple]:
    """Brute force over all pairs of open pixels: (A, B) with B in A's forbidden window."""
    rows, cols = np.nonzero(mask)
    dv = rows[None, :] - rows[:, None]
    du = cols[None, :] - cols[:, None]
    inside = (
        (np.abs(dv) < spacing.pitch)
        & (du >= -spacing.left[rows, cols][:, None])
        & (du <= spacing.right[rows, cols][:, None])
    )
    np.fill_diagonal(inside, False)
    a, b = np.nonzero(inside)
    return [((rows[i], cols[i]), (rows[j], cols[j])) for i, j in zip(a, b, strict=True)]


def odd_spacing(shape=(40, 70), seed=0) -> MaskSpacing:
    """A small spacing whose windows change from pixel to pixel (asymmetric on purpose)."""
    rng = np.random.default_rng(seed)
    left = rng.integers(2, 9, shape)
    right = rng.integers(2, 9, shape)
    return MaskSpacing(left, right, 3, 3.0, 3.0)


@pytest.fixture(scope="session")
def helpers():
    """The oracles of this module for the tests."""
    return SimpleNamespace(
        pairs_in_conflict=pairs_in_conflict, odd_spacing=odd_spacing, models=synthetic_models
    )
