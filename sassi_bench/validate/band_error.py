"""Where a Macbeth patch's error lies along the band, and what a lab should do about it.

For a patch, the per-band error is the measured reflectance minus the reference, in the
usable band, with the standard error of the patch mean (its pixel spread over the square
root of its pixel count). Its squared error is split into four shares:

* **noise**: bins whose error is within two standard errors: expose longer or repeat;
* **band edges**: bins within :data:`EDGE_NM` of either end of the usable band, where the
  light is weakest and (at the red end of a prism's band) the blur spans several bins, so
  the deblur and the blur model decide the radiometry: recalibrate the blur or narrow the
  band;
* **steep reference**: interior bins where the reference changes fastest (at least half
  its steepest slope): the blur is wider than the patch's spectral feature: change the
  optics or the prism;
* **broad**: the rest, a smooth error across the band: re-take the white reference or
  the response.

The largest share names the cause.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CLOSE_FRACTION",
    "EDGE_NM",
    "PatchBandError",
    "close_to_tolerance",
    "failing_patches",
    "patch_band_error",
]

#: Width of the band-edge zones at both ends of the usable band (nm).
EDGE_NM = 40.0

#: A passing patch whose RMSE or dE00 reaches this fraction of its tolerance is close to
#: failing: the report gives its advice; further below, it only says where the error lies.
CLOSE_FRACTION = 0.75

#: Advice per cause, for the report's sentence.
_ADVICE = {
    "noise": "noise: expose longer or repeat the scan",
    "band edges": "the band edges: recalibrate the blur (laser lines near the band's ends) "
    "or narrow the usable band",
    "steep reference": "the patch's steep spectral edge: the blur is wider than the feature; "
    "change the optics or the prism",
    "broad": "a smooth error across the band: re-take the white reference or the response",
}

#: Where the error lies, without advice (a patch well within its tolerances).
_ZONE = {
    "noise": "the noise",
    "band edges": "the band-edge zones",
    "steep reference": "the patch's steep spectral edge",
    "broad": "a smooth error across the band",
}


@dataclass(frozen=True)
class PatchBandError:
    """One patch's error per band and how it splits by cause.

    Attributes
    ----------
    patch
        Index (0-23).
    name
        The patch's name.
    error, standard_error
        (B,) measured minus reference reflectance, and the mean's standard error (NaN
        outside the usable band).
    zones
        (B,) the zone of every bin: ``"edge"``, ``"steep"``, ``"interior"`` or ``""``
        outside the usable band.
    shares
        Cause -> share of the patch's squared error in the usable band.
    failed
        Whether the patch fails a per-patch tolerance.
    close
        Whether a passing patch is close to a tolerance (:data:`CLOSE_FRACTION`): the
        report advises only on failing or close patches.
    """

    patch: int
    name: str
    error: NDArray[np.float64]
    standard_error: NDArray[np.float64]
    zones: tuple[str, ...]
    shares: dict[str, float]
    failed: bool
    close: bool = False

    @property
    def state(self) -> str:
        """``"fails"``, ``"close to a tolerance"`` or, for the patch drawn when all pass
        well, ``"largest RMSE, passes"``."""
        if self.failed:
            return "fails"
        return "close to a tolerance" if self.close else "largest RMSE, passes"

    @property
    def cause(self) -> str:
        """The cause with the largest share."""
        return max(self.shares, key=lambda k: self.shares[k])

    def sentence(self) -> str:
        """What the report says about this patch.

        Examples
        --------
        >>> e = PatchBandError(8, "Red", np.zeros(2), np.ones(2), ("edge", "interior"),
        ...                    {"noise": 0.1, "band edges": 0.7, "steep reference": 0.2,
        ...                     "broad": 0.0}, True)
        >>> e.sentence()[:52]
        'Patch 9 Red fails: 70 % of its squared error lies in'
        >>> from dataclasses import replace
        >>> replace(e, failed=False).sentence()[:80]
        'Patch 9 Red has the largest reflectance RMSE of the 24 patches, and every patch '
        """
        split = ", ".join(f"{100 * v:.0f} % {k}" for k, v in self.shares.items())
        share = f"{100 * self.shares[self.cause]:.0f} % of its squared error lies in"
        if self.failed or self.close:
            verdict = "fails" if self.failed else "passes, close to a tolerance"
            return (
                f"Patch {self.patch + 1} {self.name} {verdict}: {share} "
                f"{_ADVICE[self.cause]} ({split})."
            )
        return (
            f"Patch {self.patch + 1} {self.name} has the largest reflectance RMSE of the 24 "
            f"patches, and every patch is well within the per-patch tolerances: {share} "
            f"{_ZONE[self.cause]} ({split}); no patch alone calls for a change."
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready data."""
        return {
            "patch": self.patch + 1,
            "name": self.name,
            "failed": self.failed,
            "close": self.close,
            "cause": self.cause,
            "shares": dict(self.shares),
            "error": self.error.tolist(),
            "standard_error": self.standard_error.tolist(),
            "zones": list(self.zones),
            "sentence": self.sentence(),
        }


def failing_patches(result: Any, tolerances: Mapping[str, Any]) -> list[int]:
    """Patches over a per-patch tolerance (RMSE or dE00), worst first.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> r = SimpleNamespace(rmse=np.array([0.01, 0.03, 0.05]), de00=np.array([0.2, 0.1, 0.1]))
    >>> failing_patches(r, {"max_rmse": 0.02, "max_de00": 1.0})
    [2, 1]
    """
    bad = (np.asarray(result.rmse) > float(tolerances["max_rmse"])) | (
        np.asarray(result.de00) > float(tolerances["max_de00"])
    )
    return [int(k) for k in np.argsort(-np.asarray(result.rmse)) if bad[k]]


def close_to_tolerance(result: Any, patch: int, tolerances: Mapping[str, Any]) -> bool:
    """Whether ``patch``'s RMSE or dE00 reaches :data:`CLOSE_FRACTION` of its tolerance.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> r = SimpleNamespace(rmse=np.array([0.016, 0.002]), de00=np.array([0.2, 0.1]))
    >>> close_to_tolerance(r, 0, {"max_rmse": 0.02, "max_de00": 1.0})
    True
    >>> close_to_tolerance(r, 1, {"max_rmse": 0.02, "max_de00": 1.0})
    False
    """
    return bool(
        result.rmse[patch] >= CLOSE_FRACTION * float(tolerances["max_rmse"])
        or result.de00[patch] >= CLOSE_FRACTION * float(tolerances["max_de00"])
    )


def patch_band_error(result: Any, patch: int, failed: bool, close: bool = False) -> PatchBandError:
    """The per-band error of ``patch`` of a :class:`~sassi_bench.validate.macbeth.MacbethResult`
    (``failed``: it fails a per-patch tolerance; ``close``: it passes, close to one).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> lam = np.linspace(440.0, 700.0, 27)
    >>> ref = np.where(lam > 600, 0.5, 0.05)[None].repeat(24, 0)
    >>> measured = ref + np.where(lam > 670, 0.05, 0.0)  # error at the red end only
    >>> r = SimpleNamespace(wavelengths_nm=lam, usable=np.ones(27, bool), reference=ref,
    ...     reflectance=measured, spread=np.full((24, 27), 0.01), pixels=np.full(24, 100),
    ...     patch_names=tuple(str(k) for k in range(24)))
    >>> patch_band_error(r, 8, True).cause
    'band edges'
    """
    lam = np.asarray(result.wavelengths_nm, dtype=np.float64)
    usable = np.asarray(result.usable, dtype=bool)
    error = np.asarray(result.reflectance[patch] - result.reference[patch], dtype=np.float64)
    se = np.asarray(result.spread[patch], dtype=np.float64) / np.sqrt(
        max(int(result.pixels[patch]), 1)
    )
    error, se = np.where(usable, error, np.nan), np.where(usable, se, np.nan)
    lo, hi = lam[usable][0], lam[usable][-1]
    edge = usable & ((lam < lo + EDGE_NM) | (lam > hi - EDGE_NM))
    slope = np.abs(np.gradient(np.asarray(result.reference[patch], dtype=np.float64), lam))
    steepest = float(np.max(slope[usable], initial=0.0))
    steep = usable & ~edge & (slope >= 0.5 * steepest) & (steepest > 0)
    square = np.where(usable, error**2, 0.0)
    noise = usable & (np.abs(np.nan_to_num(error)) <= 2.0 * np.nan_to_num(se))
    total = float(square.sum()) or 1.0
    shares = {
        "noise": float(square[noise].sum()) / total,
        "band edges": float(square[edge & ~noise].sum()) / total,
        "steep reference": float(square[steep & ~noise].sum()) / total,
        "broad": float(square[usable & ~edge & ~steep & ~noise].sum()) / total,
    }
    zones = tuple(
        "" if not u else "edge" if e else "steep" if s else "interior"
        for u, e, s in zip(usable, edge, steep, strict=True)
    )
    return PatchBandError(
        patch, result.patch_names[patch], error, se, zones, shares, bool(failed), bool(close)
    )
