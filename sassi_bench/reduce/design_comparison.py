"""As designed against as built: a calibration's measured maps beside its rig's design.

On a rig whose spectral arm is an optical design (``design:``), the design predicts
where every SLM pixel lands at every wavelength and how large its spot is. A calibration
measures both (the bundle's dispersion model and its blur). This module traces the design
*as described* (never the bench's own build, which procedures do not see) on a small grid
over the field and the band, subtracts it from the measured maps, and diagnoses the
difference: every candidate misalignment (each lens decentred in x or y, the camera off
focus, the prism rolled about the axis) is traced with that one parameter nudged; its
change of the maps is fitted to the measured-minus-design difference by least squares,
refined by tracing the design with the fitted amount, and the candidate that explains the
most of the difference names the misalignment and its size.

Positions and spot widths enter the fit in units of what a calibration measures them to
(:data:`POSITION_SCALE_PX`, :data:`WIDTH_SCALE_PX`). The traces are kept in the design
cache (:func:`~sassi_bench.optics.design.cache_folder`), so a second report of the same
design traces nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from sassi_bench.optics.design import GridSpec, OpticalDesign, with_override
from sassi_bench.optics.design.cache import cached_trace
from sassi_bench.optics.design.relay import DIFFRACTION_SIGMA_PER_LAMBDA_N

__all__ = [
    "MATCH_POSITION_RMS_PX",
    "MATCH_WIDTH_RMS_PX",
    "POSITION_SCALE_PX",
    "WIDTH_SCALE_PX",
    "Candidate",
    "DesignComparison",
    "Diagnosis",
    "FieldMaps",
    "candidate_perturbations",
    "compare_with_design",
    "comparison_grid",
    "comparison_of_models",
    "design_maps",
    "measured_maps",
]

#: What a calibration measures positions to (camera px): a position difference's weight.
POSITION_SCALE_PX = 0.05
#: What a calibration measures spot widths to (camera px): a width difference's weight.
WIDTH_SCALE_PX = 0.1
#: A bench matches its design when the positions differ by at most this RMS (camera px) ...
#: (a margin over what a bench built to its design gives:
#: ``docs/notes/2026-12-01-measured-in-code-comments.md``)
MATCH_POSITION_RMS_PX = 0.2
#: ... and the spot widths by at most this RMS (camera px).
MATCH_WIDTH_RMS_PX = 0.1
#: The share of the weighted squared difference a candidate must explain to be named.
EXPLAINED_TO_NAME = 0.7
#: Candidates that explain within this share of the best are named beside it: the data
#: cannot tell them apart (a camera shifted and its lens decentred move the image alike).
ABOUT_AS_WELL = 0.02
#: Field nodes (columns, rows) and wavelengths the design is compared at (the latter
#: spread over the band the calibration measured the spot at: its blur is extrapolated
#: outside its lasers, and off there: ``docs/notes/2026-12-01-measured-in-code-comments.md``).
COMPARISON_NODES = (7, 5)
COMPARISON_WAVELENGTHS = 5


@dataclass(frozen=True)
class FieldMaps:
    """Positions and spots on a grid of SLM points x wavelengths, each (points, K).

    ``x, y`` camera px; ``cxx, cyy, cxy`` the optics' spot covariance (camera px**2,
    without the SLM pixel's image).
    """

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    wavelengths_nm: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    cxx: NDArray[np.float64]
    cyy: NDArray[np.float64]
    cxy: NDArray[np.float64]

    @property
    def width_along(self) -> NDArray[np.float64]:
        """Spot sigma along the streak (camera px)."""
        return np.sqrt(np.maximum(self.cxx, 0.0))

    @property
    def width_across(self) -> NDArray[np.float64]:
        """Spot sigma across the streak (camera px)."""
        return np.sqrt(np.maximum(self.cyy, 0.0))

    def signature(self) -> NDArray[np.float64]:
        """Positions and widths stacked, each in units of what a calibration measures."""
        return np.concatenate(
            [
                self.x.ravel() / POSITION_SCALE_PX,
                self.y.ravel() / POSITION_SCALE_PX,
                self.width_along.ravel() / WIDTH_SCALE_PX,
                self.width_across.ravel() / WIDTH_SCALE_PX,
            ]
        )


@dataclass(frozen=True)
class Candidate:
    """One misalignment the diagnosis tries: a named change of the described design.

    ``override(amount)`` is the design override (``with_override`` keys) for an amount in
    ``unit``; ``step`` the nudge its sensitivity is traced with; ``scale`` and
    ``shown_unit`` how an amount is written (mm shown as um).
    """

    name: str
    unit: str
    step: float
    override: Callable[[float], dict[str, Any]]
    scale: float = 1.0
    shown_unit: str = ""

    def describe(self, amount: float) -> str:
        """The candidate with an amount, as a lab reads it.

        Examples
        --------
        >>> lens = Candidate("lens decentred in y", "mm", 0.02, dict, 1000.0, "um")
        >>> lens.describe(0.05), lens.describe(-1.2)
        ('lens decentred in y by +50 um', 'lens decentred in y by -1.2 mm')
        """
        shown = amount * self.scale
        if abs(shown) >= 1000.0 and self.scale != 1.0:  # a millimetre or more: in the unit
            return f"{self.name} by {amount:+.3g} {self.unit}"
        return f"{self.name} by {shown:+.3g} {self.shown_unit or self.unit}"


@dataclass(frozen=True)
class Diagnosis:
    """A candidate fitted to the measured-minus-design difference.

    ``amount`` in the candidate's unit; ``explained`` the share of the weighted squared
    difference it removes (1: all of it).
    """

    candidate: Candidate
    amount: float
    explained: float

    @property
    def sentence(self) -> str:
        """The candidate, its amount and what it explains."""
        return f"{self.candidate.describe(self.amount)} (explains {100 * self.explained:.0f} %)"


@dataclass(frozen=True)
class DesignComparison:
    """The measured maps against the design's prediction, and the verdict.

    ``design`` and ``measured`` on the same grid; ``diagnoses`` every candidate, best first
    (empty when the bench matches its design).
    """

    design: FieldMaps
    measured: FieldMaps
    diagnoses: tuple[Diagnosis, ...]

    @property
    def position_difference_px(self) -> NDArray[np.float64]:
        """Distance between measured and designed positions (camera px), (points, K)."""
        return np.hypot(self.measured.x - self.design.x, self.measured.y - self.design.y)

    @property
    def width_difference_px(self) -> NDArray[np.float64]:
        """Measured minus designed spot sigma along and across, stacked: (2, points, K)."""
        return np.stack(
            [
                self.measured.width_along - self.design.width_along,
                self.measured.width_across - self.design.width_across,
            ]
        )

    @property
    def position_rms_px(self) -> float:
        """RMS of :attr:`position_difference_px`."""
        return float(np.sqrt(np.mean(self.position_difference_px**2)))

    @property
    def width_rms_px(self) -> float:
        """RMS of :attr:`width_difference_px`."""
        return float(np.sqrt(np.mean(self.width_difference_px**2)))

    @property
    def matches(self) -> bool:
        """Whether the bench matches its design within the calibration's own accuracy."""
        return (
            self.position_rms_px <= MATCH_POSITION_RMS_PX
            and self.width_rms_px <= MATCH_WIDTH_RMS_PX
        )

    @property
    def best(self) -> Diagnosis | None:
        """The candidate that explains the difference, or None (a match, or none does)."""
        if self.matches or not self.diagnoses:
            return None
        best = self.diagnoses[0]
        return best if best.explained >= EXPLAINED_TO_NAME else None

    @property
    def named(self) -> tuple[Diagnosis, ...]:
        """The best candidate and those that explain about as much (best first); empty when
        nothing is named."""
        best = self.best
        if best is None:
            return ()
        return tuple(d for d in self.diagnoses if d.explained >= best.explained - ABOUT_AS_WELL)

    @property
    def verdict(self) -> str:
        """One sentence for the report."""
        sizes = (
            f"positions differ by {self.position_rms_px:.2f} px RMS, spot widths by "
            f"{self.width_rms_px:.2f} px RMS"
        )
        if self.matches:
            return (
                f"The bench matches its design: {sizes} (within {MATCH_POSITION_RMS_PX} and "
                f"{MATCH_WIDTH_RMS_PX} px)."
            )
        named = self.named
        if named:
            text = f"The bench is off its design ({sizes}): {named[0].sentence}."
            if len(named) > 1:
                others = "; ".join(d.sentence for d in named[1:])
                text += f" These fit about as well (the maps cannot tell them apart): {others}."
            return text
        tried = self.diagnoses[0].sentence if self.diagnoses else "nothing"
        return (
            f"The bench is off its design ({sizes}), in a way no single misalignment "
            f"explains (the closest: {tried}); check its alignment against the design."
        )

    def to_json(self) -> dict[str, Any]:
        """The verdict and the candidates, JSON-compatible (the bundle's quality section)."""
        return {
            "matches": self.matches,
            "verdict": self.verdict,
            "position_rms_px": self.position_rms_px,
            "width_rms_px": self.width_rms_px,
            "diagnosis": [
                {
                    "candidate": d.candidate.name,
                    "amount": d.amount if np.isfinite(d.amount) else None,
                    "unit": d.candidate.unit,
                    "explained": d.explained if np.isfinite(d.explained) else None,
                }
                for d in self.diagnoses
            ],
        }


def comparison_grid(
    slm_shape: tuple[int, int], camera_shape: tuple[int, int], band_nm: tuple[float, float]
) -> GridSpec:
    """The grid a design is compared on: :data:`COMPARISON_NODES` over the SLM (to its
    edges) at :data:`COMPARISON_WAVELENGTHS` wavelengths spanning ``band_nm`` (the lines
    the calibration measured the spot at).

    Examples
    --------
    >>> spec = comparison_grid((200, 320), (288, 512), (450.0, 670.0))
    >>> spec.u_nodes()[:2].tolist(), spec.wavelengths_nm().tolist()
    ([0.0, 53.166666666666664], [450.0, 505.0, 560.0, 615.0, 670.0])
    """
    start, stop = (float(b) for b in band_nm)
    step = (stop - start) / (COMPARISON_WAVELENGTHS - 1)
    columns, rows = COMPARISON_NODES
    return GridSpec(
        slm_shape, camera_shape, start, stop, step, columns=columns, rows=rows, margin=0.0
    )


def design_maps(design: OpticalDesign, spec: GridSpec) -> FieldMaps:
    """The design's positions and optics spots at the nodes of ``spec`` (traced once, then
    read from the design cache): the traced centroids and moments plus the diffraction
    core, as the virtual bench renders a design.

    Examples
    --------
    Not run here (it needs the ray tracer)::

        maps = design_maps(desc.design, comparison_grid((200, 320), (288, 512), (450, 670)))
    """
    grid = cached_trace(design, spec)
    n_working = 1.0 / (2.0 * grid.image_na)
    lam = grid.wavelengths_nm
    core = (
        DIFFRACTION_SIGMA_PER_LAMBDA_N * lam * 1e-3 * n_working / design.camera_pixel_pitch_um
    ) ** 2
    uu, vv = np.meshgrid(grid.u, grid.v, indexing="ij")
    points = uu.size

    def flat(a: NDArray) -> NDArray:
        return a.reshape(points, lam.size)

    return FieldMaps(
        u=uu.ravel(),
        v=vv.ravel(),
        wavelengths_nm=lam,
        x=flat(grid.x),
        y=flat(grid.y),
        cxx=flat(np.maximum(grid.sxx, 0.0)) + core,
        cyy=flat(np.maximum(grid.syy, 0.0)) + core,
        cxy=flat(grid.sxy),
    )


def measured_maps(models: Any, u: NDArray, v: NDArray, wavelengths_nm: NDArray) -> FieldMaps:
    """A calibration's positions (its dispersion model) and optics spots (its blur, less
    the SLM pixel's image) at SLM points (u[i], v[i]) and every wavelength.

    Parameters
    ----------
    models
        The bundle's :class:`~sassi_bench.bundle.CalibrationModels` (``dispersion``,
        ``blur``).
    u, v
        SLM points (P,).
    wavelengths_nm
        Wavelengths (K,).

    Examples
    --------
    >>> maps = measured_maps(bundle.models, np.array([10.0]), np.array([5.0]), np.array([550.0]))
    >>> maps.x.shape
    (1, 1)
    """
    uu = np.asarray(u, np.float64)[:, None]
    vv = np.asarray(v, np.float64)[:, None]
    lam = np.asarray(wavelengths_nm, np.float64)[None, :]
    x, y = models.dispersion.evaluate(uu, vv, lam)
    shape = np.broadcast_shapes(uu.shape, lam.shape)
    spot = models.blur.spot(
        np.broadcast_to(uu, shape), np.broadcast_to(vv, shape), np.broadcast_to(lam, shape)
    )
    pixel = float(getattr(models.blur, "pixel_variance_px2", 0.0) or 0.0)
    along, across = np.asarray(spot.along), np.asarray(spot.across)
    return FieldMaps(
        u=uu.ravel(),
        v=vv.ravel(),
        wavelengths_nm=lam.ravel(),
        x=np.broadcast_to(x, shape).astype(np.float64),
        y=np.broadcast_to(y, shape).astype(np.float64),
        cxx=along**2 - pixel,
        cyy=across**2 - pixel,
        cxy=np.asarray(spot.correlation) * along * across,
    )


def _elements(design: OpticalDesign) -> tuple[list[tuple[int, ...]], tuple[int, ...] | None]:
    """The lenses (runs of surfaces, numbered from 1, from air through glass back to air,
    untilted) and the prism's surfaces (its tilted entry face to its exit face)."""
    lenses: list[tuple[int, ...]] = []
    prism: tuple[int, ...] | None = None
    run: list[int] = []
    in_prism = False
    for number, surface in enumerate(design.surfaces, 1):
        if surface.is_break:
            continue
        if run:
            run.append(number)
            if surface.material == "air":
                if in_prism:
                    prism = prism or tuple(run)
                else:
                    lenses.append(tuple(run))
                run, in_prism = [], False
        elif surface.material != "air":
            run, in_prism = [number], surface.is_tilted
    return lenses, prism


def _decentred(design: OpticalDesign, surfaces: Sequence[int], axis: int) -> Callable:
    def override(amount: float) -> dict[str, Any]:
        changed = {}
        for number in surfaces:
            decenter = list(design.surfaces[number - 1].decenter_mm)
            decenter[axis] += amount
            changed[number] = {"decenter_mm": decenter}
        return {"surfaces": changed}

    return override


def _shifted(design: OpticalDesign, axis: int) -> Callable:
    def override(amount: float) -> dict[str, Any]:
        decenter = list(design.image_decenter_mm)
        decenter[axis] += amount
        return {"image": {"decenter_mm": decenter}}

    return override


def _refocused(design: OpticalDesign) -> Callable:
    last = len(design.surfaces)
    thickness = design.surfaces[-1].thickness_mm

    def override(amount: float) -> dict[str, Any]:
        return {"surfaces": {last: {"thickness_mm": thickness + amount}}}

    return override


def _rolled(design: OpticalDesign, surfaces: Sequence[int]) -> Callable:
    def override(amount: float) -> dict[str, Any]:
        roll = Rotation.from_euler("z", amount, degrees=True)
        changed = {}
        for number in surfaces:
            tilt = Rotation.from_euler("XYZ", design.surfaces[number - 1].tilt_deg, degrees=True)
            changed[number] = {"tilt_deg": (roll * tilt).as_euler("XYZ", degrees=True).tolist()}
        return {"surfaces": changed}

    return override


def candidate_perturbations(design: OpticalDesign) -> list[Candidate]:
    """The misalignments the diagnosis tries on a design: every lens decentred in x and in
    y (its surfaces together), the camera shifted in x and in y (the image plane's
    decenter) and moved along the axis (the last thickness), and the prism rolled about
    the axis.

    Examples
    --------
    >>> from sassi_bench.optics.design import OpticalDesign
    >>> design = OpticalDesign.from_mapping({
    ...     "slm_pixel_pitch_um": 8.0, "camera_pixel_pitch_um": 5.5,
    ...     "object_distance_mm": 25.0, "aperture": {"object_space_na": 0.02},
    ...     "surfaces": [{"radius_mm": 12.9, "thickness_mm": 3.0, "material": "N-BK7",
    ...                   "stop": True}, {"thickness_mm": 20.0}]})
    >>> for candidate in candidate_perturbations(design):
    ...     print(candidate.name)
    lens 1 (surfaces 1-2) decentred in x
    lens 1 (surfaces 1-2) decentred in y
    camera shifted in x
    camera shifted in y
    camera off focus
    >>> candidate_perturbations(design)[4].override(0.05)
    {'surfaces': {2: {'thickness_mm': 20.05}}}
    """
    lenses, prism = _elements(design)
    candidates = []
    for k, surfaces in enumerate(lenses, 1):
        where = f"surfaces {surfaces[0]}-{surfaces[-1]}"
        if prism is not None:
            role = "collimator" if surfaces[0] < prism[0] else "camera lens"
            label = f"{role} ({where})"
        else:
            label = f"lens {k} ({where})"
        for axis, name in enumerate("xy"):
            candidates.append(
                Candidate(
                    f"{label} decentred in {name}",
                    "mm",
                    0.02,
                    _decentred(design, surfaces, axis),
                    scale=1000.0,
                    shown_unit="um",
                )
            )
    for axis, name in enumerate("xy"):
        candidates.append(
            Candidate(f"camera shifted in {name}", "mm", 0.02, _shifted(design, axis), 1e3, "um")
        )
    candidates.append(Candidate("camera off focus", "mm", 0.02, _refocused(design), 1000.0, "um"))
    if prism is not None:
        candidates.append(
            Candidate(
                f"prism (surfaces {prism[0]}-{prism[-1]}) rolled",
                "deg",
                0.2,
                _rolled(design, prism),
            )
        )
    return candidates


def _weighted_sum(r: NDArray) -> float:
    return float(np.sum(np.where(np.isfinite(r), r, 0.0) ** 2))


def _fit(change: NDArray, target: NDArray) -> float:
    """Least-squares multiple of ``change`` closest to ``target`` (non-finite entries left
    out: rays vignetted at a node in one trace and not the other)."""
    ok = np.isfinite(change) & np.isfinite(target)
    norm = float(change[ok] @ change[ok])
    return float(change[ok] @ target[ok]) / norm if norm > 0 else float("nan")


def compare_with_design(
    design: OpticalDesign,
    measured: FieldMaps,
    spec: GridSpec,
    candidates: Sequence[Candidate] | None = None,
    refine: int = 2,
    refine_top: int = 2,
    progress: Callable[[int, int], None] | None = None,
) -> DesignComparison:
    """Compare measured maps with the design and diagnose the difference.

    Parameters
    ----------
    design
        The design as described (what procedures see).
    measured
        The calibration's maps at the nodes of ``spec`` (:func:`measured_maps`).
    spec
        The comparison grid (:func:`comparison_grid`).
    candidates
        The misalignments to try (default :func:`candidate_perturbations`).
    refine, refine_top
        Secant steps for each of the ``refine_top`` candidates the linear fits explain
        best, each tracing the design with the fitted amount (the maps are not linear in
        a misalignment: a spot's width in a defocus); the others keep their linear fit.
    progress
        Called with (traces done, traces planned).

    Returns
    -------
    DesignComparison

    Examples
    --------
    Not run here (it needs the ray tracer)::

        spec = comparison_grid(slm_shape, camera_shape, (450.0, 670.0))
        nominal = design_maps(desc.design, spec)
        found = compare_with_design(desc.design, measured_maps(models, nominal.u, nominal.v,
                                                               nominal.wavelengths_nm), spec)
        print(found.verdict)
    """
    nominal = design_maps(design, spec)
    comparison = DesignComparison(nominal, measured, ())
    if comparison.matches:
        return comparison
    candidates = list(candidate_perturbations(design) if candidates is None else candidates)
    base = nominal.signature()
    difference = measured.signature() - base
    total = _weighted_sum(difference)
    planned = len(candidates) + min(refine_top, len(candidates)) * refine
    done = 0

    def traced(candidate: Candidate, amount: float) -> NDArray:
        nonlocal done
        changed = with_override(design, candidate.override(amount), "design comparison")
        maps = design_maps(changed, spec)
        done += 1
        if progress is not None:
            progress(done, planned)
        return maps.signature() - base

    def explained(model: NDArray) -> float:
        # Where a changed design loses a node (its rays vignetted), it explains nothing there.
        model = np.where(np.isfinite(model), model, 0.0)
        return 1.0 - _weighted_sum(difference - model) / total if total > 0 else 0.0

    # Linear: each candidate's traced change per unit, fitted alone.
    linear = []
    for candidate in candidates:
        change = traced(candidate, candidate.step)
        multiple = _fit(change, difference)
        amount = multiple * candidate.step if np.isfinite(multiple) else 0.0
        linear.append((candidate, amount, change, explained(change * amount / candidate.step)))
    linear.sort(key=lambda item: -item[3])
    diagnoses = [Diagnosis(c, a, e) for c, a, _, e in linear[refine_top:]]
    # Secant steps for the leading candidates on the design traced with the fitted amount.
    for candidate, amount, change, share in linear[:refine_top]:
        previous, previous_change = candidate.step, change
        for _ in range(refine):
            if amount == previous:
                break
            here = traced(candidate, amount)
            share = explained(here)
            slope = (here - previous_change) / (amount - previous)
            previous, previous_change = amount, here
            step = _fit(slope, difference - here)
            if not np.isfinite(step):
                break
            amount += step
        # The amount whose trace gave ``share``: the last traced one.
        diagnoses.append(Diagnosis(candidate, previous, share))
    diagnoses.sort(key=lambda d: -d.explained)
    return DesignComparison(nominal, measured, tuple(diagnoses))


def comparison_of_models(
    design: OpticalDesign,
    models: Any,
    slm_shape: tuple[int, int],
    camera_shape: tuple[int, int],
    band_nm: tuple[float, float],
    progress: Callable[[int, int], None] | None = None,
) -> DesignComparison:
    """A calibration's models (:class:`~sassi_bench.bundle.CalibrationModels`) against the
    described design: :func:`compare_with_design` on :func:`comparison_grid`.

    Examples
    --------
    Not run here (it needs the ray tracer)::

        found = comparison_of_models(desc.design, models, (200, 320), (288, 512), (450, 670))
    """
    spec = comparison_grid(slm_shape, camera_shape, band_nm)
    nominal = design_maps(design, spec)
    measured = measured_maps(models, nominal.u, nominal.v, nominal.wavelengths_nm)
    return compare_with_design(design, measured, spec, progress=progress)
