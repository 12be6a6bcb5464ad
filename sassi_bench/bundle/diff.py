"""What changed between two bundles, in the units a scientist checks.

* wavelength map: camera-pixel shift of every (field point, bin centre) of bundle A, and the
  same shift in nm (which wavelength bundle B puts where bundle A put the bin centre);
* guide homography: how far an SLM point moves when mapped guide -> SLM with B instead of A;
* blur sigma at A's bin centres;
* bins, procedure parameters, quality checks, inputs, rig and software.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle.bundle import CalibrationBundle
from sassi_bench.bundle.jsonio import thaw

__all__ = ["BundleDiff", "diff_bundles", "format_diff"]

_NEWTON_STEPS = 8
_DERIV_STEP_NM = 1e-3


@dataclass(frozen=True)
class Stats:
    """Max and RMS of a difference (absolute values)."""

    max: float
    rms: float

    @classmethod
    def of(cls, values: NDArray[np.float64]) -> Stats:
        """Stats of an array (NaNs ignored)."""
        finite = np.abs(values[np.isfinite(values)])
        if finite.size == 0:
            return cls(float("nan"), float("nan"))
        return cls(float(finite.max()), float(np.sqrt(np.mean(finite**2))))


@dataclass(frozen=True)
class BundleDiff:
    """Differences between bundle ``a`` and bundle ``b`` (``b − a``).

    Attributes
    ----------
    map_shift_px
        Euclidean camera shift over the field grid and A's bin centres.
    map_shift_x_px, map_shift_y_px
        The x and y components.
    map_shift_nm
        Wavelength shift at fixed camera position.
    bins
        ``(count_a, count_b, max |centre change| nm or None)``.
    homography
        ``"unchanged"``, ``"changed"``, ``"added"``, ``"removed"`` or ``"absent"``.
    homography_shift_px
        SLM-pixel shift over the SLM grid and corners, when both bundles have one.
    blur_sigma_px
        Change of sigma at A's bin centres.
    procedure
        ``(dotted key, old, new)`` for every changed parameter (missing = ``"<absent>"``).
    quality
        ``(check name, old, new)`` with ``"value unit PASS/FAIL"`` strings.
    other
        Other changes in words (rig, software, inputs, status, SLM shape).
    """

    a: str
    b: str
    map_shift_px: Stats
    map_shift_x_px: Stats
    map_shift_y_px: Stats
    map_shift_nm: Stats
    bins: tuple[int, int, float | None]
    homography: str
    homography_shift_px: Stats | None
    blur_sigma_px: Stats
    procedure: list[tuple[str, Any, Any]] = field(default_factory=list)
    quality: list[tuple[str, str, str]] = field(default_factory=list)
    other: list[str] = field(default_factory=list)


def _field_grid(shape: tuple[int, int], n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    height, width = shape
    u, v = np.meshgrid(np.linspace(0, width - 1, n), np.linspace(0, height - 1, n))
    return u.ravel(), v.ravel()


def _wavelength_shift(
    b: CalibrationBundle,
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    lam: NDArray[np.float64],
    x_target: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Solve ``x_b(u, v, λ') = x_target`` for ``λ'`` by vectorised Newton steps; return λ' − λ."""
    guess = np.broadcast_to(lam, x_target.shape).copy()
    with np.errstate(all="ignore"):
        for _ in range(_NEWTON_STEPS):
            x_now, _ = b.slm_to_camera(u, v, guess)
            x_hi, _ = b.slm_to_camera(u, v, guess + _DERIV_STEP_NM)
            x_lo, _ = b.slm_to_camera(u, v, guess - _DERIV_STEP_NM)
            slope = (x_hi - x_lo) / (2 * _DERIV_STEP_NM)
            guess = guess - (x_now - x_target) / slope
    return guess - lam


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, Mapping):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flatten(item, f"{prefix}.{key}" if prefix else str(key)))
        if not value and prefix:
            out[prefix] = {}
        return out
    return {prefix: thaw(value)}


def _check_text(check: Mapping[str, Any] | None) -> str:
    if check is None:
        return "<absent>"
    status = "PASS" if check["passed"] else "FAIL"
    return f"{check['value']:.4g} {check['unit']} {status}".replace("  ", " ")


def diff_bundles(a: CalibrationBundle, b: CalibrationBundle, *, grid: int = 9) -> BundleDiff:
    """Compare two loaded bundles.

    Parameters
    ----------
    a, b
        The older and the newer bundle (differences are ``b − a``).
    grid
        Field points per side of the SLM grid used for the maps (corners included).

    Returns
    -------
    BundleDiff

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> d = diff_bundles(load(rig="sim", version=1), load(rig="sim", version=2))
    >>> d.a, d.b
    ('sim/v0001', 'sim/v0002')
    """
    other: list[str] = []
    shape_a, shape_b = a.slm_shape, b.slm_shape
    if shape_a != shape_b:
        other.append(f"SLM shape {shape_a} -> {shape_b}; maps compared over the common area")
    common = (min(shape_a[0], shape_b[0]), min(shape_a[1], shape_b[1]))
    u, v = _field_grid(common, grid)
    u, v = u[:, None], v[:, None]
    lam = a.wavelengths[None, :]
    xa, ya = a.slm_to_camera(u, v, lam)
    xb, yb = b.slm_to_camera(u, v, lam)
    shift_nm = _wavelength_shift(b, u, v, lam, xa)

    count_a, count_b = a.wavelengths.size, b.wavelengths.size
    centre_change = (
        float(np.max(np.abs(b.wavelengths - a.wavelengths))) if count_a == count_b else None
    )

    homography, homography_shift = _homography_change(a, b, grid)
    sigma_change = b.blur_width(a.wavelengths) - a.blur_width(a.wavelengths)

    proc_a = _flatten(thaw(a.manifest["procedure"]))
    proc_b = _flatten(thaw(b.manifest["procedure"]))
    procedure = [
        (key, proc_a.get(key, "<absent>"), proc_b.get(key, "<absent>"))
        for key in sorted(set(proc_a) | set(proc_b))
        if proc_a.get(key, "<absent>") != proc_b.get(key, "<absent>")
    ]

    checks_a = {c["name"]: c for c in a.manifest["quality"]["checks"]}
    checks_b = {c["name"]: c for c in b.manifest["quality"]["checks"]}
    quality = []
    for name in sorted(set(checks_a) | set(checks_b)):
        old, new = _check_text(checks_a.get(name)), _check_text(checks_b.get(name))
        if old != new:
            quality.append((name, old, new))

    if a.passed != b.passed:
        other.append(
            f"status {'passed' if a.passed else 'FAILED'} -> {'passed' if b.passed else 'FAILED'}"
        )
    if a.manifest["rig_hash"] != b.manifest["rig_hash"]:
        other.append("rig description changed (rig_hash differs)")
    soft_a, soft_b = a.manifest["software"], b.manifest["software"]
    if (soft_a["version"], soft_a["git_commit"]) != (soft_b["version"], soft_b["git_commit"]):
        other.append(
            f"software {soft_a['version']} ({soft_a['git_commit'] or 'no git'}) -> "
            f"{soft_b['version']} ({soft_b['git_commit'] or 'no git'})"
        )
    inputs_a = {i["id"]: i["sha256"] for i in a.manifest["inputs"]}
    inputs_b = {i["id"]: i["sha256"] for i in b.manifest["inputs"]}
    if inputs_a != inputs_b:
        added = sorted(set(inputs_b) - set(inputs_a))
        removed = sorted(set(inputs_a) - set(inputs_b))
        changed = sorted(k for k in set(inputs_a) & set(inputs_b) if inputs_a[k] != inputs_b[k])
        other.append(
            f"inputs: added {added or '-'}, removed {removed or '-'}, changed {changed or '-'}"
        )
    if a.models.offset != b.models.offset:
        other.append(f"offset model {thaw(a.models.offset)} -> {thaw(b.models.offset)}")
    if (a.response is None) != (b.response is None):
        other.append(f"response {'added' if a.response is None else 'removed'}")
    elif a.response is not None and b.response is not None and a.response.shape == b.response.shape:
        change = float(np.max(np.abs(b.response - a.response)))
        if change > 0:
            other.append(f"response: max change {change:.4g}")

    return BundleDiff(
        a=f"{a.rig_name}/{a.version}",
        b=f"{b.rig_name}/{b.version}",
        map_shift_px=Stats.of(np.hypot(xb - xa, yb - ya)),
        map_shift_x_px=Stats.of(xb - xa),
        map_shift_y_px=Stats.of(yb - ya),
        map_shift_nm=Stats.of(shift_nm),
        bins=(count_a, count_b, centre_change),
        homography=homography,
        homography_shift_px=homography_shift,
        blur_sigma_px=Stats.of(sigma_change),
        procedure=procedure,
        quality=quality,
        other=other,
    )


def _homography_change(
    a: CalibrationBundle, b: CalibrationBundle, grid: int
) -> tuple[str, Stats | None]:
    ha, hb = a.guide_to_slm, b.guide_to_slm
    if ha is None and hb is None:
        return "absent", None
    if ha is None:
        return "added", None
    if hb is None:
        return "removed", None
    u, v = _field_grid(a.slm_shape, grid)
    slm = np.stack([u, v, np.ones_like(u)])
    # An SLM point -> guide pixel with A's inverse -> back to the SLM with B's homography.
    back = hb @ np.linalg.solve(ha, slm)
    with np.errstate(all="ignore"):
        moved = back[:2] / back[2]
    stats = Stats.of(np.hypot(moved[0] - u, moved[1] - v))
    return ("unchanged" if np.array_equal(ha, hb) else "changed"), stats


def format_diff(diff: BundleDiff) -> str:
    """Readable multi-line report of a :class:`BundleDiff`.

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> a, b = load(rig="sim", version=1), load(rig="sim", version=2)
    >>> print(format_diff(diff_bundles(a, b)))  # doctest: +NORMALIZE_WHITESPACE
    bundle diff sim/v0001 -> sim/v0002
    wavelength map: shift max 0 px (rms 0 px; x max 0 px, y max 0 px),
        in wavelength max 0 nm (rms 0 nm)
    bins: 68, centres moved max 0 nm
    guide homography: removed
    blur sigma: change max 0 px (rms 0 px) over the bins
    procedure parameters: unchanged
    quality checks: unchanged
    response removed
    """
    lines = [f"bundle diff {diff.a} -> {diff.b}"]
    m = diff.map_shift_px
    lines.append(
        f"wavelength map: shift max {m.max:.3g} px (rms {m.rms:.3g} px; "
        f"x max {diff.map_shift_x_px.max:.3g} px, y max {diff.map_shift_y_px.max:.3g} px), "
        f"in wavelength max {diff.map_shift_nm.max:.3g} nm (rms {diff.map_shift_nm.rms:.3g} nm)"
    )
    count_a, count_b, centre = diff.bins
    if count_a != count_b:
        lines.append(f"bins: {count_a} -> {count_b}")
    else:
        lines.append(f"bins: {count_a}, centres moved max {centre:.3g} nm")
    if diff.homography_shift_px is not None and diff.homography != "unchanged":
        h = diff.homography_shift_px
        lines.append(
            f"guide homography: {diff.homography}, SLM points move max {h.max:.3g} px "
            f"(rms {h.rms:.3g} px)"
        )
    else:
        lines.append(f"guide homography: {diff.homography}")
    b = diff.blur_sigma_px
    lines.append(f"blur sigma: change max {b.max:.3g} px (rms {b.rms:.3g} px) over the bins")
    if diff.procedure:
        lines.append("procedure parameters changed:")
        lines.extend(f"  {key}: {old!r} -> {new!r}" for key, old, new in diff.procedure)
    else:
        lines.append("procedure parameters: unchanged")
    if diff.quality:
        lines.append("quality checks changed:")
        lines.extend(f"  {name}: {old} -> {new}" for name, old, new in diff.quality)
    else:
        lines.append("quality checks: unchanged")
    lines.extend(diff.other)
    return "\n".join(lines)
