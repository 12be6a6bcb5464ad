"""Dispersion fit: where every SLM pixel's light of every wavelength lands.

Input: per-laser smooth maps ``(u, v) -> (x, y)`` (:class:`LaserMap`). Output: the
bundle's dispersion model, in which camera column ``x`` and row ``y`` are quadratics in
the prism glass's refractive index ``n(λ)``, with every coefficient a smooth (Legendre)
function of the SLM field:

    x(u, v, λ) = Σ_k Σ_t a_kt P_t(û, v̂) s_x(λ)^k,   s_x = (n(λ) − n_ref) / n_scale
    y(u, v, λ) = Σ_k Σ_t c_kt P_t(û, v̂) s_x(λ)^k

The paper's row, a quadratic in ``s_y = (λ − 550 nm) / 150 nm`` (coefficients ``b_kt``),
is fitted too and kept in the bundle for readers of its older schema; a prism's rows
follow its index, which a polynomial in wavelength cannot follow into the blue.

The honest accuracy figure is the leave-one-laser-out error: refit without one laser
and predict where that laser's light lands. The same refit also says which wavelength
the left-out line really has (the one whose predicted streak position matches it best):
:func:`check_laser_lines` uses it to find a laser whose true line is off its label, and
:func:`fit_dispersion` can then fit with the estimated wavelength instead of the label.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import DispersionModel, WavelengthBins
from sassi_bench.calibrate.field import FieldFit
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.optics.glass import Glass, get_glass

__all__ = [
    "DispersionFit",
    "LaserLine",
    "LaserMap",
    "check_laser_lines",
    "fit_dispersion",
    "wavelength_bins",
]

LAMBDA_REF_NM = 550.0
LAMBDA_SCALE_NM = 150.0
BAND_NM = (400.0, 700.0)


@dataclass(frozen=True)
class LaserMap:
    """The smooth SLM -> camera map measured under one laser line."""

    wavelength_nm: float
    x: FieldFit
    y: FieldFit
    n_correspondences: int
    counts: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class DispersionFit:
    """Result of :func:`fit_dispersion`.

    Attributes
    ----------
    model
        The bundle's :class:`~sassi_bench.bundle.DispersionModel`.
    bins
        Wavelength bins, one per camera column of the 400-700 nm streak at the field centre.
    residual_px
        Per laser, RMS (x, y) distance between the joint model and that laser's own map.
    leave_one_out
        Per laser (keyed by its label), the error predicting it from the others:
        ``rms_px``, ``max_px`` (2-D distance over the field), ``rms_nm`` (column error
        over the local dispersion) and ``estimated_nm`` (the wavelength at which the
        others put the line's streak where it was measured).
    position_sigma_px
        Largest 1-sigma uncertainty of the predicted column at the field centre over
        400-700 nm. Each laser map's error is taken as one smooth surface over the field
        (about as many independent numbers as the field has terms), its size the larger
        of the lines' scatter about the joint model and the map's own correspondence
        scatter, and carried through the fit (the lamp lines' normal equations included
        when anchored) to the centre column.
    position_sigma_nm
        The same 1-sigma in nm, wavelength by wavelength (the column's 1-sigma over the
        local dispersion there), the largest over 400-700 nm: the column is least sure
        where the map reaches past its lines, which need not be where the dispersion is
        lowest.
    position_sigma_rms_nm, position_sigma_rms_px
        That 1-sigma in nm and in camera px, RMS over 400-700 nm (the statistic the
        map's wavelength accuracy is graded by).
    wavelengths_nm
        Per laser label, the wavelength the fit used: the label, or the estimate for a
        line fitted with an estimated wavelength.
    anchored
        Whether lamp lines anchor the fit (every laser at its lamp-anchored wavelength,
        the lamp streaks in every refit): then every line is graded by leave-one-out.
    line_sigma_nm, line_sigma_max_nm
        The map's 1-sigma (nm) at the field centre from the uncertainty of the wavelengths
        its lines are fitted at (``wavelength_sigma_nm`` of :func:`fit_dispersion`: each
        line moved by its 1-sigma and the fit made again, in quadrature): RMS over
        400-700 nm, and the worst there (most where the map reaches past its lines);
        0 when every line is exact.
    form_sigma_rms_nm
        The part of the stated 1-sigma that is the column form's miss under the anchored
        fit's weighting (``form_error_px`` of :func:`fit_dispersion`), RMS over
        400-700 nm; 0 when none was given.
    """

    model: DispersionModel
    bins: WavelengthBins
    residual_px: dict[float, float]
    leave_one_out: dict[float, dict[str, float]]
    position_sigma_px: float
    position_sigma_nm: float
    position_sigma_rms_nm: float
    position_sigma_rms_px: float
    wavelengths_nm: dict[float, float] = field(default_factory=dict)
    anchored: bool = False
    line_sigma_nm: float = 0.0
    line_sigma_max_nm: float = 0.0
    form_sigma_rms_nm: float = 0.0

    @property
    def estimated_lines(self) -> list[float]:
        """Labels of the lines fitted at an estimated wavelength instead of their label."""
        return [label for label, used in self.wavelengths_nm.items() if used != label]

    @property
    def interior_lines(self) -> list[float]:
        """Labels with a laser line on both sides: their leave-one-out refit interpolates.

        Leaving out the bluest or the reddest line asks the others to extrapolate the
        dispersion curve to it: its error measures the distance to the next line, not the
        map (docs/rig_family.md). Those are recorded (``leave_one_out``,
        :attr:`extrapolation_max_px`), not graded.
        """
        labels = sorted(self.leave_one_out)
        return labels[1:-1]

    def _graded(self, key: str) -> list[float]:
        # A line fitted at its own leave-one-out estimate predicts itself by construction,
        # so it is left out of the graded leave-one-out figures; a lamp-anchored line's
        # wavelength comes from the lamps, so its refit is a real test. The end lines are
        # extrapolations (``interior_lines``).
        skip = set() if self.anchored else set(self.estimated_lines)
        interior = set(self.interior_lines)
        return [
            entry[key]
            for label, entry in self.leave_one_out.items()
            if label not in skip and label in interior
        ]

    @property
    def leave_one_out_rms_nm(self) -> float:
        """RMS over the interior lasers of the leave-one-laser-out wavelength error (lines
        fitted at their estimated wavelength left out)."""
        values = self._graded("rms_nm")
        return float(np.sqrt(np.mean(np.square(values)))) if values else float("nan")

    @property
    def leave_one_out_max_px(self) -> float:
        """Worst leave-one-laser-out position error (same lines as the RMS)."""
        values = self._graded("max_px")
        return float(max(values)) if values else float("nan")

    @property
    def extrapolation_max_px(self) -> float:
        """Worst position error predicting the bluest or reddest line from the others
        (recorded: how far the map reaches beyond its lines, not graded)."""
        ends = [v["max_px"] for k, v in self.leave_one_out.items() if k not in self.interior_lines]
        return float(max(ends)) if ends else float("nan")


def _grid(slm_shape: tuple[int, int], points: tuple[int, int]) -> tuple[NDArray, NDArray]:
    h, w = slm_shape
    v, u = np.meshgrid(
        np.linspace(0, h - 1, points[1]), np.linspace(0, w - 1, points[0]), indexing="ij"
    )
    return u.ravel(), v.ravel()


@dataclass(frozen=True)
class _FieldSamples:
    """Every laser's measured map sampled on a grid of SLM field points."""

    glass: Glass
    n_ref: float
    n_scale: float
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    field_design: NDArray[np.float64]
    xs: NDArray[np.float64]  # (lasers, points)
    ys: NDArray[np.float64]

    def sx(self, wavelength_nm) -> NDArray[np.float64]:
        """The column's spectral coordinate ``(n(λ) - n_ref) / n_scale``."""
        return (self.glass.index(np.asarray(wavelength_nm, dtype=np.float64)) - self.n_ref) / (
            self.n_scale
        )

    @cached_property
    def field_pinv(self) -> NDArray[np.float64]:
        """Pseudo-inverse of the field design (terms, points)."""
        return np.linalg.pinv(self.field_design)

    def fit_x(
        self, wavelength_nm: NDArray[np.float64], rows, order: int, information=None
    ) -> NDArray[np.float64]:
        """Column coefficients (order + 1, terms) fitted to the lasers ``rows``.

        The design is the Kronecker product of the spectral powers and the field terms,
        so its least-squares solution is ``pinv(powers) @ x @ pinv(field).T``, without
        building it. ``information`` (an
        :class:`~sassi_bench.calibrate.anchored.XInformation`) adds the lamp lines' normal
        equations; the system is then solved whole.
        """
        powers = self.sx(wavelength_nm[rows])[:, None] ** np.arange(order + 1)[None, :]
        if information is None:
            return np.linalg.pinv(powers) @ self.xs[rows] @ self.field_pinv.T
        normal = np.kron(powers.T @ powers, self.field_design.T @ self.field_design)
        rhs = (powers.T @ self.xs[rows] @ self.field_design).ravel()
        coeffs = np.linalg.solve(normal + information.matrix, rhs + information.vector)
        return coeffs.reshape(order + 1, -1)

    def line_wavelength(self, x_coeffs: NDArray[np.float64], row: int, start_nm: float) -> float:
        """The wavelength at which columns ``x_coeffs`` best put laser ``row``'s streak.

        Least squares over the field points in the spectral coordinate (Gauss-Newton;
        the column is a low-order polynomial in it), then back to nanometres.
        """
        per_point = x_coeffs @ self.field_design.T  # (order + 1, points)
        powers = np.arange(per_point.shape[0])
        s = float(self.sx(start_nm))
        for _ in range(50):
            value = (s**powers) @ per_point
            slope = (powers[1:] * s ** powers[:-1]) @ per_point[1:]
            step = float(np.sum((value - self.xs[row]) * slope) / np.sum(slope**2))
            s -= step
            if abs(step) < 1e-12:
                break
        lam = np.linspace(start_nm - 60.0, start_nm + 60.0, 12001)
        coordinate = self.sx(lam)  # decreasing: the index falls with wavelength
        return float(np.interp(-s, -coordinate, lam))


def _field_samples(
    maps: Sequence[LaserMap], glass: Glass, slm_shape, field_degree: int, grid
) -> _FieldSamples:
    u, v = _grid(slm_shape, grid)
    return _FieldSamples(
        glass=glass,
        n_ref=float(glass.index(LAMBDA_REF_NM)),
        n_scale=float(glass.index(BAND_NM[0]) - glass.index(BAND_NM[1])),
        u=u,
        v=v,
        field_design=legendre2d_design(*field_coordinates(u, v, slm_shape), field_degree),
        xs=np.stack([m.x(u, v) for m in maps]),
        ys=np.stack([m.y(u, v) for m in maps]),
    )


def _checked_wavelengths(maps: Sequence[LaserMap], order: int) -> NDArray[np.float64]:
    lam = np.array([m.wavelength_nm for m in maps], dtype=np.float64)
    if lam.size < order + 1:
        raise ProcedureError(
            step_error(
                "dispersion fit",
                f"{lam.size} laser line(s) cannot fix a degree-{order} dispersion model",
                f"measure at least {order + 1} lines (the procedure's lasers_nm)",
            )
        )
    if np.unique(lam).size != lam.size:
        raise ProcedureError(
            step_error("dispersion fit", "a laser wavelength appears twice", "list each line once")
        )
    return lam


def fit_dispersion(
    maps: Sequence[LaserMap],
    glass: str | Glass,
    slm_shape: tuple[int, int],
    field_degree: int = 5,
    order: int = 2,
    grid: tuple[int, int] = (33, 21),
    wavelengths_nm: Mapping[float, float] | None = None,
    x_information=None,
    wavelength_sigma_nm: Mapping[float, float] | None = None,
    form_error_px: ArrayLike | None = None,
    wavelength_correlation: Mapping[tuple[float, float], float] | None = None,
) -> DispersionFit:
    """Fit the joint dispersion model to per-laser maps.

    Parameters
    ----------
    maps
        One :class:`LaserMap` per laser line (at least ``order + 1`` lines; one more for
        the leave-one-laser-out error).
    glass
        The prism glass (its Sellmeier index defines ``s_x``).
    slm_shape
        SLM (height, width).
    field_degree, order
        Legendre degree of the coefficient fields; polynomial order in ``s``.
    grid
        Field points (columns, rows) at which the per-laser maps are compared.
    wavelengths_nm
        Label -> wavelength to fit that line at instead of its label (an estimate from
        :func:`check_laser_lines` or the lamp-anchored fit); lines left out are fitted at
        their labels.
    x_information
        The lamp lines' normal equations for the column coefficients
        (:class:`~sassi_bench.calibrate.anchored.XInformation`), added to the fit and to
        every leave-one-laser-out refit; the fit is then ``anchored``.
    wavelength_sigma_nm
        Label -> the 1-sigma of the wavelength that line is fitted at (a test sheet's
        accuracy, a lamp measurement's uncertainty); lines left out are exact. Carried
        into the map (``line_sigma_nm``, ``line_sigma_max_nm``).
    form_error_px
        How far the column's form misses the optics under the anchored fit's weighting,
        px, at 31 wavelengths over 400-700 nm
        (:func:`~sassi_bench.calibrate.anchored_form.anchored_form_error_px`): added in
        quadrature to the stated 1-sigma at each (``position_sigma_*``).
    wavelength_correlation
        (label, label) -> the correlation of those two lines' wavelength errors (lines
        estimated together), each pair once in either order; pairs left out are
        independent.

    Returns
    -------
    DispersionFit

    Raises
    ------
    ValueError
        With too few laser lines or duplicated wavelengths.
    """
    g = glass if isinstance(glass, Glass) else get_glass(glass)
    labels = _checked_wavelengths(maps, order)
    used = {float(k): float(v) for k, v in (wavelengths_nm or {}).items()}
    lam = np.array([used.get(float(label), float(label)) for label in labels])
    samples = _field_samples(maps, g, slm_shape, field_degree, grid)
    u, v, xs, ys = samples.u, samples.v, samples.xs, samples.ys
    sy = (lam - LAMBDA_REF_NM) / LAMBDA_SCALE_NM
    sx = samples.sx(lam)

    def fit(keep: NDArray[np.bool_]):
        ax = samples.fit_x(lam, keep, order, x_information)
        # The rows' design is the Kronecker product of the powers of the spectral
        # coordinate and the field terms: its least squares is
        # pinv(powers) @ ys @ pinv(field).T (as for x). The rows are fitted in the index
        # (what the bundle evaluates) and in wavelength (the paper's form, kept for
        # readers of the older schema).
        ay = [
            np.linalg.pinv(s[keep][:, None] ** np.arange(order + 1)[None, :])
            @ ys[keep]
            @ samples.field_pinv.T
            for s in (sy, sx)
        ]
        return ax, ay

    def model_from(ax, ay) -> DispersionModel:
        return DispersionModel(
            glass=g.name,
            sellmeier_b=g.b,
            sellmeier_c=g.c,
            n_ref=samples.n_ref,
            n_scale=samples.n_scale,
            lambda_ref_nm=LAMBDA_REF_NM,
            lambda_scale_nm=LAMBDA_SCALE_NM,
            slm_shape=tuple(slm_shape),
            field_degree=field_degree,
            x_coeffs=ax,
            y_coeffs=ay[0],
            y_index_coeffs=ay[1],
        )

    everything = np.ones(lam.size, dtype=bool)
    model = model_from(*fit(everything))
    px, py = model.evaluate(u[None, :], v[None, :], lam[:, None])
    residual = {
        float(labels[i]): float(np.sqrt(np.mean((px[i] - xs[i]) ** 2 + (py[i] - ys[i]) ** 2)))
        for i in range(lam.size)
    }
    leave_one_out: dict[float, dict[str, float]] = {}
    if lam.size > order + 1:
        for i in range(lam.size):
            keep = everything.copy()
            keep[i] = False
            ax, ay = fit(keep)
            qx, qy = model_from(ax, ay).evaluate(u, v, lam[i])
            dist = np.hypot(qx - xs[i], qy - ys[i])
            dx_dlam = _dispersion_px_per_nm(model, u, v, lam[i])
            leave_one_out[float(labels[i])] = {
                "rms_px": float(np.sqrt(np.mean(dist**2))),
                "max_px": float(dist.max()),
                "rms_nm": float(np.sqrt(np.mean(((qx - xs[i]) / dx_dlam) ** 2))),
                "estimated_nm": samples.line_wavelength(ax, i, float(lam[i])),
            }
    sigma_px, slope = _centre_position_sigma(samples, model, lam, maps, order, x_information)
    form_px = np.zeros_like(sigma_px)
    if form_error_px is not None:
        form_px = np.asarray(form_error_px, dtype=np.float64)
    sigma_px = np.hypot(sigma_px, form_px)
    sigma_nm = sigma_px / slope
    form_nm = form_px / slope

    def refit_x(moved: NDArray[np.float64]) -> DispersionModel:
        return model_from(
            samples.fit_x(moved, everything, order, x_information),
            (model.y_coeffs, model.y_index_coeffs),
        )

    line_rms, line_max = _line_wavelength_sigma(
        model, refit_x, labels, lam, wavelength_sigma_nm or {}, wavelength_correlation or {}
    )
    return DispersionFit(
        model=model,
        bins=wavelength_bins(model),
        residual_px=residual,
        leave_one_out=leave_one_out,
        position_sigma_px=float(sigma_px.max()),
        position_sigma_nm=float(sigma_nm.max()),
        position_sigma_rms_nm=float(np.sqrt(np.mean(sigma_nm**2))),
        position_sigma_rms_px=float(np.sqrt(np.mean(sigma_px**2))),
        wavelengths_nm={float(label): float(w) for label, w in zip(labels, lam, strict=True)},
        anchored=x_information is not None,
        line_sigma_nm=line_rms,
        line_sigma_max_nm=line_max,
        form_sigma_rms_nm=float(np.sqrt(np.mean(form_nm**2))),
    )


@dataclass(frozen=True)
class LaserLine:
    """Whether a laser line sits where its label says, judged by the other lines.

    Attributes
    ----------
    label_nm
        The line's nominal wavelength (the rig's ``lasers_nm``).
    estimated_nm
        The wavelength at which a dispersion model fitted to ``from_lines`` puts the
        line's measured streak.
    from_lines
        The labels of the lines the estimate comes from (never the line itself).
    off_label
        Whether the line was singled out as the one off its label: the worst line
        beyond its allowance while the others agree within theirs.
    propagated_nm
        How far the estimate moves when the ``from_lines`` are off their labels by their
        stated accuracy (quadrature sum of each line's accuracy times the estimate's
        derivative with respect to that line's wavelength). An interior line's estimate
        moves about as much as its neighbours may; an end line's is an extrapolation
        and moves many times more (measured on the rig family:
        docs/notes/2026-11-30-rig-family-lamps.md).
    """

    label_nm: float
    estimated_nm: float
    from_lines: tuple[float, ...]
    off_label: bool
    propagated_nm: float = 0.0

    @property
    def offset_nm(self) -> float:
        """Estimated minus nominal wavelength (nm)."""
        return self.estimated_nm - self.label_nm

    def allowed_nm(self, tolerance_nm: float) -> float:
        """How far the estimate may be from the label on a right bundle: the line's own
        ``tolerance_nm`` and the estimate's :attr:`propagated_nm`, in quadrature.

        Examples
        --------
        >>> LaserLine(635.0, 635.3, (450.0, 520.0, 670.0), False, 0.4).allowed_nm(0.3)
        0.5
        """
        return float(np.hypot(tolerance_nm, self.propagated_nm))


def check_laser_lines(
    maps: Sequence[LaserMap],
    glass: str | Glass,
    slm_shape: tuple[int, int],
    tolerance_nm: float,
    field_degree: int = 5,
    order: int = 2,
    grid: tuple[int, int] = (33, 21),
    accuracy_nm: Mapping[float, float] | None = None,
) -> dict[float, LaserLine]:
    """Estimate every laser line's wavelength from the other lines; find one off its label.

    Each line's wavelength is estimated from a dispersion model fitted to the other
    lines, and allowed to be off its label by ``tolerance_nm`` and, in quadrature, by how
    far the others' own stated accuracy moves the estimate
    (:attr:`LaserLine.propagated_nm`): an end line's estimate is an extrapolation, which
    the others' small errors move by nanometres, so a right bundle's end line can sit
    there and the check says so rather than fail it. One mislabelled line spoils the
    estimates of the others too (most of all the ones extrapolated to), so when some line
    is beyond its allowance each line in turn is set aside and the rest estimated from
    each other without it: the line whose absence brings all the others within their
    allowances is the one off its label, and its estimate comes from all the others. That
    needs each remaining estimate to rest on at least ``order + 1`` lines (five lines for
    the quadratic model). Otherwise, or when no single line explains it, the lines beyond
    their allowance stay so and no line is blamed.

    Parameters
    ----------
    maps, glass, slm_shape, field_degree, order, grid
        As for :func:`fit_dispersion`.
    tolerance_nm
        How far a line may be off its label (the procedure's ``laser_line_nm``).
    accuracy_nm
        Per label, how far its true line may be from it as the rig states (a test
        sheet's accuracy, ``laser_tolerance_nm``); capped at ``tolerance_nm`` (a right
        bundle has no line further off), which is also the value of lines not named.

    Returns
    -------
    dict
        Label -> :class:`LaserLine`, in the order of ``maps``.

    Examples
    --------
    Not run here (it needs measured laser maps)::

        lines = check_laser_lines(maps, "N-BK7", (400, 640), 0.5)
        [f"{k:g}: {x.estimated_nm:.1f}" for k, x in lines.items() if x.off_label]
        # ['635: 637.8']
    """
    g = glass if isinstance(glass, Glass) else get_glass(glass)
    labels = _checked_wavelengths(maps, order)
    samples = _field_samples(maps, g, slm_shape, field_degree, grid)
    everyone = list(range(labels.size))
    stated = {float(k): float(v) for k, v in (accuracy_nm or {}).items()}
    accuracy = np.array([min(stated.get(float(x), tolerance_nm), tolerance_nm) for x in labels])

    def estimate(i: int, rows: list[int]) -> tuple[float, list[int], float]:
        """Line ``i`` estimated from ``rows``, with the estimate's propagated accuracy."""
        at = samples.line_wavelength(samples.fit_x(labels, np.array(rows), order), i, labels[i])
        # The estimate is smooth in the others' wavelengths: a finite difference per line
        # gives its derivative (the fit is a few small products, so this is cheap).
        step = 0.1
        moved = []
        for j in rows:
            shifted = labels.copy()
            shifted[j] += step
            ax = samples.fit_x(shifted, np.array(rows), order)
            moved.append((samples.line_wavelength(ax, i, labels[i]) - at) / step * accuracy[j])
        return at, rows, float(np.sqrt(np.sum(np.square(moved))))

    def estimates_within(group: list[int]) -> dict[int, tuple[float, list[int], float]]:
        """Each line of ``group`` estimated from the rest of the group."""
        others = {i: [j for j in group if j != i] for i in group}
        return {i: estimate(i, rows) for i, rows in others.items() if len(rows) >= order + 1}

    def worst(found: dict[int, tuple[float, list[int], float]]) -> float:
        """The largest offset over its allowance (above 1: beyond it)."""
        return max(
            (abs(e - labels[i]) / math.hypot(tolerance_nm, p) for i, (e, _, p) in found.items()),
            default=0.0,
        )

    found = estimates_within(everyone)
    culprit = None
    if worst(found) > 1.0 and labels.size - 2 >= order + 1:
        without = {c: estimates_within([j for j in everyone if j != c]) for c in everyone}
        best = min(everyone, key=lambda c: worst(without[c]))
        if worst(without[best]) <= 1.0:
            culprit = best
            found = {**without[best], best: found[best]}
    return {
        float(labels[i]): LaserLine(
            label_nm=float(labels[i]),
            estimated_nm=float(found[i][0]) if i in found else float("nan"),
            from_lines=tuple(float(labels[j]) for j in found[i][1]) if i in found else (),
            off_label=i == culprit,
            propagated_nm=float(found[i][2]) if i in found else 0.0,
        )
        for i in everyone
    }


def _dispersion_px_per_nm(model: DispersionModel, u, v, wavelength_nm: float) -> NDArray:
    step = 0.05
    lo, _ = model.evaluate(u, v, wavelength_nm - step)
    hi, _ = model.evaluate(u, v, wavelength_nm + step)
    return (hi - lo) / (2 * step)


def _line_wavelength_sigma(model, refit, labels, lam, sigma_nm, correlation) -> tuple[float, float]:
    """The map's wavelength at the field centre over the band, moved by each line's
    wavelength 1-sigma in turn (``refit``: the model fitted at moved wavelengths), summed
    through the lines' correlations (in quadrature where they are independent): its RMS
    over the band and its largest, nm."""
    h, w = model.slm_shape
    band = np.linspace(*BAND_NM, 31)
    centre = ((w - 1) / 2, (h - 1) / 2)
    x0 = np.asarray(model.evaluate(*centre, band)[0], dtype=np.float64).ravel()
    slope = np.maximum(np.abs(np.gradient(x0, band)), 1e-12)
    moves: dict[float, NDArray[np.float64]] = {}
    for i, label in enumerate(labels):
        sigma = float(sigma_nm.get(float(label), 0.0))
        if sigma <= 0:
            continue
        moved = lam.copy()
        moved[i] += sigma
        x1 = np.asarray(refit(moved).evaluate(*centre, band)[0], dtype=np.float64)
        moves[float(label)] = x1.ravel() - x0
    moved_px2 = sum((m**2 for m in moves.values()), np.zeros_like(band))
    pairs = {tuple(sorted((float(a), float(b)))): rho for (a, b), rho in correlation.items()}
    for (a, b), rho in pairs.items():
        if a != b and a in moves and b in moves:
            moved_px2 = moved_px2 + 2.0 * rho * moves[a] * moves[b]
    moved_nm = np.sqrt(np.clip(moved_px2, 0.0, None)) / slope
    return float(np.sqrt(np.mean(moved_nm**2))), float(moved_nm.max())


def _centre_position_sigma(
    samples: _FieldSamples,
    model: DispersionModel,
    lam: NDArray[np.float64],
    maps: Sequence[LaserMap],
    order: int,
    information=None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The column's 1-sigma at the field centre at each of 31 wavelengths over the band,
    camera px, and the local dispersion there (px per nm).

    Each laser map's error is one smooth surface over the field, not independent grid
    samples: a map carries about as many independent numbers as the field has terms
    (``T``), however densely it is sampled. So the per-point variance of a map's error is
    taken as the larger of the lines' scatter about the joint model at each field point
    (``L - K`` degrees of freedom each; it includes where the model's form misses the
    optics) and the map's own correspondence scatter (its fit's RMS squared times its
    terms over its inliers); and the error surfaces are given the field design's covariance
    scaled to that variance (``G / T`` times the hat matrix). The centre column is a
    linear function of the maps (through the lamp lines' normal equations too, when the
    fit is anchored), so its variance is each map's sensitivity through that covariance,
    summed over the maps, plus the lamp streaks' own photon noise carried through the
    same normal equations (:meth:`~sassi_bench.calibrate.anchored.XInformation.noise_variance`).
    """
    field_design = samples.field_design
    points, terms = field_design.shape
    powers = samples.sx(lam)[:, None] ** np.arange(order + 1)[None, :]  # (L, K)
    gram = field_design.T @ field_design
    normal = np.kron(powers.T @ powers, gram)
    if information is not None:
        normal = normal + information.matrix
    h, w = model.slm_shape
    centre = legendre2d_design(
        *field_coordinates((w - 1) / 2, (h - 1) / 2, model.slm_shape), model.field_degree
    ).ravel()
    band = np.linspace(*BAND_NM, 31)
    band_powers = model.spectral_x(band)[:, None] ** np.arange(order + 1)[None, :]
    rows = np.einsum("nk,t->nkt", band_powers, centre).reshape(band.size, -1)
    solved = np.linalg.solve(normal, rows.T).T
    through = solved.reshape(band.size, order + 1, terms)
    # Sensitivity of the centre column at each band wavelength to laser l's map,
    # expressed in field terms: d x_c / d xs[l] = A[l] @ field_design.T.
    sensitivity = np.einsum("lk,nkt->lnt", powers, through)
    squared = np.einsum("lnt,ts,lns->ln", sensitivity, gram, sensitivity)
    predicted = powers @ model.x_coeffs.reshape(order + 1, terms) @ field_design.T
    spare = lam.size - (order + 1)
    scatter = float(np.sum((samples.xs - predicted) ** 2)) / (points * spare) if spare > 0 else 0.0
    own = np.array([m.x.rms**2 * m.x.coeffs.size / max(m.x.n_inliers, 1) for m in maps])
    variance = np.maximum(own, scatter)[:, None] * (points / terms) * squared
    lamps = 0.0 if information is None else information.noise_variance(solved)
    sigma_px = np.sqrt(variance.sum(axis=0) + lamps)
    slope = np.abs(np.ravel(_dispersion_px_per_nm(model, (w - 1) / 2, (h - 1) / 2, band)))
    return sigma_px, np.maximum(slope, 1e-12)


def wavelength_bins(
    model: DispersionModel, band_nm: tuple[float, float] = BAND_NM
) -> WavelengthBins:
    """One wavelength bin per camera column of the streak at the field centre.

    The bin centred on camera column ``k`` spans columns ``k - 1/2 .. k + 1/2``; columns
    run from the first at or after the ``band_nm[0]`` end of the centre pixel's streak to
    the last at or before its ``band_nm[1]`` end.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.zeros((3, 1)); x[0, 0] = 400.0; x[1, 0] = -60.0
    >>> m = DispersionModel("N-BK7", (1.03961212, 0.231792344, 1.01046945),
    ...                     (0.00600069867, 0.0200179144, 103.560653), 1.5185, 0.0178,
    ...                     550.0, 150.0, (400, 640), 0, x, np.zeros((3, 1)))
    >>> bins = wavelength_bins(m)
    >>> bins.count, bool(np.all(np.diff(bins.edges_nm) > 0))
    (60, True)
    """
    h, w = model.slm_shape
    lam = np.linspace(band_nm[0] - 30.0, band_nm[1] + 30.0, 36001)
    x, _ = model.evaluate((w - 1) / 2, (h - 1) / 2, lam)
    if np.any(np.diff(x) <= 0):
        raise ProcedureError(
            step_error(
                "wavelength bins",
                "the fitted streak is not monotonic in wavelength at the field centre",
                "check the laser wavelengths and the sweep decoding",
            )
        )
    x_lo, x_hi = np.interp(band_nm, lam, x)
    columns = np.arange(np.ceil(x_lo), np.floor(x_hi) + 1)
    centres = np.interp(columns, x, lam)
    edges = np.interp(np.append(columns - 0.5, columns[-1] + 0.5), x, lam)
    return WavelengthBins(centres_nm=centres, edges_nm=edges, resolution_nm=np.diff(edges))
