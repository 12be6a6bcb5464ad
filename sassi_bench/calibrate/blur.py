"""Blur fit: the width of one SLM pixel's spot on the camera, versus wavelength.

Spot widths are measured on pinhole frames under each laser line, across the
dispersion (along camera rows' normal, i.e. in y), where the laser's own line width
does not widen them. The width is the spot's second moment, so it is the same number a
Gaussian of that sigma would give whatever the exact spot shape.

The SASSI paper fits those widths with a quadratic in wavelength. A spot is the optics'
PSF convolved with the SLM pixel's image and the camera pixel, two boxes whose variance
does not depend on the wavelength, so its width is ``sqrt(psf(λ)² + p)``: flat near the
PSF's narrowest wavelength, steep away from it, a shape a quadratic in the spot width
cannot follow between lasers far apart (measured:
``docs/notes/2026-11-29-docstring-measurements.md``).

Given the SLM pixel's image (:func:`fit_blur`'s ``aperture_px``) the quadratic is fitted
to the PSF instead (:class:`~sassi_bench.bundle.QuadraticBlur` ``"psf_quadratic"``), and the
model is the spot *before* the camera pixel, ``sqrt(psf² + aperture²/12)``: every user of
the bundle's blur integrates its Gaussian over camera pixels (the scan's row unmixing over
each cell's rows, the streak's forward model over each bin's columns, the lamp spots over
a pixel box), so a width that held the camera pixel's ``1/12`` px² too would count it
twice. The measured second moments are fitted as ``sqrt(model² + 1/12)``.

Where no laser is, the curve is the model's guess. The fit states how good a guess it is
(``relative_error``, from leaving each laser out), and the scan's anchor spectrum allows
for the forward model's error by it; leaving a line out makes the figure pessimistic,
by a similar factor on every rig measured (the note above).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import QuadraticBlur
from sassi_bench.bundle.blur.field_covariance import FieldCovarianceBlur, wavelength_terms
from sassi_bench.calibrate.dispersion import LAMBDA_REF_NM, LAMBDA_SCALE_NM
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design, legendre2d_terms

__all__ = [
    "CAMERA_PIXEL_VARIANCE_PX2",
    "BlurFit",
    "SpotMoments",
    "SpotWidths",
    "fit_blur",
    "fit_field_covariance",
    "measure_spot_widths",
]

#: Variance (px²) one camera pixel's box adds to a spot's measured second moment.
CAMERA_PIXEL_VARIANCE_PX2 = 1.0 / 12.0


@dataclass(frozen=True)
class SpotWidths:
    """Second-moment widths of spots (camera px)."""

    sigma_x: NDArray[np.float64]
    sigma_y: NDArray[np.float64]
    valid: NDArray[np.bool_]
    #: The second cross moment (camera px**2): negative when the spot leans the other way.
    cov_xy: NDArray[np.float64] | None = None

    @property
    def median_sigma_y(self) -> float:
        """Median cross-dispersion width over the valid spots."""
        return float(np.median(self.sigma_y[self.valid]))


def _windows(image: NDArray, x: NDArray, y: NDArray, half: int):
    """Patches (N, 2h+1, 2h+1) around rounded centres; ``inside`` marks full windows."""
    cx = np.rint(x).astype(np.intp)
    cy = np.rint(y).astype(np.intp)
    offsets = np.arange(-half, half + 1)
    rows = cy[:, None, None] + offsets[None, :, None]
    cols = cx[:, None, None] + offsets[None, None, :]
    inside = (cy - half >= 0) & (cy + half < image.shape[0])
    inside &= (cx - half >= 0) & (cx + half < image.shape[1])
    patches = image[np.clip(rows, 0, image.shape[0] - 1), np.clip(cols, 0, image.shape[1] - 1)]
    return patches, rows, cols, inside


def measure_spot_widths(
    signal: ArrayLike,
    x: ArrayLike,
    y: ArrayLike,
    sigma_guess: float,
    saturated: ArrayLike | None = None,
    window_sigmas: float = 4.5,
) -> SpotWidths:
    """Measure the widths of isolated spots at known positions.

    Parameters
    ----------
    signal
        Background-free image (e.g. a pinhole frame minus a closed-SLM frame), float.
    x, y
        Predicted spot centres (camera px), (N,).
    sigma_guess
        Rough width used for the first window; the window is then re-sized once from the
        measured median width.
    saturated
        Boolean image of saturated pixels; spots touching one are invalid.
    window_sigmas
        Half-width of the measurement window in sigmas.

    Returns
    -------
    SpotWidths

    Examples
    --------
    >>> yy, xx = np.mgrid[0:40, 0:40]
    >>> spot = np.exp(-((xx - 20.3) ** 2 + (yy - 19.6) ** 2) / (2 * 1.5**2))
    >>> w = measure_spot_widths(spot, [20.3], [19.6], sigma_guess=1.0)
    >>> round(float(w.sigma_y[0]), 2)
    1.5
    """
    image = np.asarray(signal, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    sigma = float(sigma_guess)
    for _ in range(3):
        half = max(2, int(np.ceil(window_sigmas * sigma)))
        patches, rows, cols, inside = _windows(image, x, y, half)
        total = patches.sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            my = (patches * rows).sum(axis=(1, 2)) / total
            mx = (patches * cols).sum(axis=(1, 2)) / total
            vy = (patches * (rows - my[:, None, None]) ** 2).sum(axis=(1, 2)) / total
            vx = (patches * (cols - mx[:, None, None]) ** 2).sum(axis=(1, 2)) / total
            vxy = (patches * (cols - mx[:, None, None]) * (rows - my[:, None, None])).sum(
                axis=(1, 2)
            ) / total
        valid = inside & (total > 0) & (vy > 0) & (vx > 0)
        if saturated is not None:
            sat = np.asarray(saturated, dtype=bool)
            hit = sat[np.clip(rows, 0, sat.shape[0] - 1), np.clip(cols, 0, sat.shape[1] - 1)]
            valid &= ~hit.any(axis=(1, 2))
        if not valid.any():
            raise ProcedureError(
                step_error(
                    "blur measurement",
                    "no spot could be measured (all off the frame, dark or saturated)",
                    "check the pinhole frames' exposure and the laser",
                )
            )
        new_sigma = float(np.median(np.sqrt(vy[valid])))
        if abs(new_sigma - sigma) < 0.02 * sigma:
            break
        sigma = new_sigma
    return SpotWidths(
        sigma_x=np.sqrt(np.abs(vx)), sigma_y=np.sqrt(np.abs(vy)), valid=valid, cov_xy=vxy
    )


@dataclass(frozen=True)
class BlurFit:
    """Result of :func:`fit_blur`: the model and how well it fits the measurements."""

    model: QuadraticBlur | FieldCovarianceBlur
    wavelengths_nm: NDArray[np.float64]
    measured_sigma_px: NDArray[np.float64]
    residual_px: NDArray[np.float64]

    #: The fit's stated 1-sigma (camera px) of the spot widths it predicts, the worst over
    #: the field and the lines' band (``field_covariance``; None: unstated).
    width_sigma_px: float | None = None

    @property
    def rms_px(self) -> float:
        """RMS of the fit residuals at the measured lines."""
        return float(np.sqrt(np.mean(self.residual_px**2)))

    def camera_width_px(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The spot width a camera measures, as the model predicts it: its sigma, with the
        camera pixel's box for a ``"psf_quadratic"`` model (which leaves that box to its
        users). The residuals are the measured widths' difference from it.

        Examples
        --------
        >>> fit = fit_blur([450, 520, 635, 670], [1.2, 0.8, 1.5, 2.3], aperture_px=1.0)
        >>> bool(fit.camera_width_px(520.0) > fit.model.sigma(520.0))
        True
        """
        sigma = self.model.sigma(wavelength_nm)
        if self.model.kind in ("psf_quadratic", "field_covariance"):
            return np.sqrt(sigma**2 + CAMERA_PIXEL_VARIANCE_PX2)
        return sigma


def fit_blur(
    wavelengths_nm: Sequence[float],
    sigma_px: Sequence[float],
    window_sigmas: float = 3.0,
    aperture_px: float | None = None,
) -> BlurFit:
    """Fit ``sigma(λ)``: a quadratic in wavelength, of the spot or of the optics' PSF.

    Parameters
    ----------
    wavelengths_nm, sigma_px
        Measured spot widths (second moments on the camera, px) at three or more
        wavelengths.
    window_sigmas
        The model's summation window, in sigmas.
    aperture_px
        RMS side (camera px) of one SLM pixel's open area as imaged on the camera, across
        the dispersion (its box adds ``aperture_px² / 12``). Given, the model is
        ``"psf_quadratic"``: the PSF a quadratic, the model's width the spot before the
        camera pixel ``sqrt(psf² + aperture_px²/12)``, fitted by least squares as
        ``sqrt(model² + 1/12)`` to the measured widths. None fits the paper's quadratic to
        the measured widths themselves.

    Returns
    -------
    BlurFit
        Its residuals compare what the model predicts a camera measures with what it did.
        With four lines or more the model states its own error where no line is
        (``relative_error``): the RMS, relative to the measured widths, of each line's
        width predicted by the fit to the others, capped at 0.5. The outermost lines
        count too: the band's ends are extrapolated past them.

    Raises
    ------
    ProcedureError
        With fewer than three wavelengths, or a spot no wider than the pixel boxes.

    Examples
    --------
    >>> fit = fit_blur([405, 450, 520, 635, 670], [1.9, 1.2, 0.7, 1.9, 2.6])
    >>> bool(fit.model.sigma(520.0) < fit.model.sigma(670.0))
    True
    >>> lam = np.array([450.0, 520.0, 532.0, 635.0, 670.0])
    >>> psf = 0.4 + 2.0 * ((lam - 530.0) / 150.0) ** 2
    >>> measured = np.sqrt(psf**2 + 1.2**2 / 12 + 1 / 12)
    >>> fit = fit_blur(lam, measured, aperture_px=1.2)
    >>> fit.model.kind, round(float(fit.model.sigma(590.0)), 4), round(fit.rms_px, 6)
    ('psf_quadratic', 0.799, 0.0)
    >>> round(fit.model.relative_error, 6)  # the PSF is a quadratic: nothing missed
    0.0
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    sig = np.asarray(sigma_px, dtype=np.float64)
    if lam.size < 3:
        raise ProcedureError(
            step_error(
                "blur fit",
                f"only {lam.size} line(s) measured; a quadratic needs three",
                "measure the blur under at least three laser lines",
            )
        )
    t = (lam - LAMBDA_REF_NM) / LAMBDA_SCALE_NM
    aperture_variance = 0.0 if aperture_px is None else float(aperture_px) ** 2 / 12.0
    measured = _SpotWidthModel(t, aperture_variance)
    coeffs = measured.fit(sig)
    error = None
    if lam.size >= 4:  # three are left to fit when one is out
        missed = np.array([measured.left_out(sig, i) for i in range(lam.size)]) / sig
        error = float(np.sqrt(np.mean(missed**2)))
    model = QuadraticBlur(
        tuple(float(c) for c in coeffs),
        LAMBDA_REF_NM,
        LAMBDA_SCALE_NM,
        window_sigmas,
        pixel_variance_px2=aperture_variance,
        relative_error=min(error, 0.5) if error is not None else None,
    )
    return BlurFit(model, lam, sig, measured.predict(coeffs, np.arange(lam.size)) - sig)


@dataclass(frozen=True)
class _SpotWidthModel:
    """The measured spot widths as a function of the model's coefficients."""

    t: NDArray[np.float64]
    pixel_variance: float

    def fit(self, sigma: NDArray[np.float64], keep: NDArray[np.intp] | None = None):
        keep = np.arange(self.t.size) if keep is None else keep
        if self.pixel_variance == 0.0:
            return np.polynomial.polynomial.polyfit(self.t[keep], sigma[keep], 2)
        total = self.pixel_variance + CAMERA_PIXEL_VARIANCE_PX2
        return _fit_psf_quadratic(self.t[keep], sigma[keep], total)

    def predict(self, coeffs, index) -> NDArray[np.float64]:
        model = np.polynomial.polynomial.polyval(self.t[index], coeffs)
        if self.pixel_variance == 0.0:
            return model
        return np.sqrt(model**2 + self.pixel_variance + CAMERA_PIXEL_VARIANCE_PX2)

    def left_out(self, sigma: NDArray[np.float64], i: int) -> float:
        """The width at line ``i`` predicted by the fit to the others, minus its own."""
        coeffs = self.fit(sigma, np.delete(np.arange(self.t.size), i))
        return float(self.predict(coeffs, [i])[0] - sigma[i])


def _fit_psf_quadratic(
    t: NDArray[np.float64], sigma: NDArray[np.float64], pixel_variance: float
) -> NDArray[np.float64]:
    """The PSF quadratic whose ``sqrt(psf² + pixel_variance)`` fits ``sigma`` best.

    Starts from the quadratic through the PSF widths the spots imply, then Gauss-Newton
    on the spot widths themselves (the PSF's widths amplify the noise of spots near the
    pixel boxes' width).
    """
    if not np.all(sigma**2 > pixel_variance):
        narrowest = float(sigma.min())
        raise ProcedureError(
            step_error(
                "blur fit",
                f"a measured spot ({narrowest:.3f} px) is no wider than the pixel boxes alone "
                f"({np.sqrt(pixel_variance):.3f} px)",
                "check the rig's slm.fill_factor and the pinhole frames' focus",
            )
        )
    powers = t[:, None] ** np.arange(3)[None, :]
    coeffs = np.linalg.lstsq(powers, np.sqrt(sigma**2 - pixel_variance), rcond=None)[0]
    for _ in range(20):
        psf = powers @ coeffs
        model = np.sqrt(psf**2 + pixel_variance)
        jacobian = powers * (psf / model)[:, None]
        step = np.linalg.lstsq(jacobian, sigma - model, rcond=None)[0]
        coeffs = coeffs + step
        if np.max(np.abs(step)) < 1e-12:
            break
    # The PSF's sign is free (only its square enters): keep it positive at the reference.
    return coeffs if coeffs[0] >= 0 else -coeffs


@dataclass(frozen=True)
class SpotMoments:
    """Pinhole spots' measured second moments (camera px**2, camera pixel included), with
    where they were: SLM pixel (u, v) and the line's wavelength, all (N,)."""

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    wavelength_nm: NDArray[np.float64]
    cxx: NDArray[np.float64]
    cyy: NDArray[np.float64]
    cxy: NDArray[np.float64]


def fit_field_covariance(
    spots: SpotMoments,
    slm_shape: tuple[int, int],
    pixel_variance_px2: float,
    window_sigmas: float = 3.0,
    field_degree: int = 4,
    wavelength_degree: int | None = None,
    wavelength_coordinate: str = "inverse_square",
    extrapolate_linearly: bool = True,
) -> BlurFit:
    """Fit the field-covariance blur (:class:`FieldCovarianceBlur`) to pinhole spots'
    second moments over the field and lines.

    Each component of the spot's covariance before the camera pixel (the measured moment
    less ``1/12`` px**2 on each axis) is a Legendre series of ``field_degree`` over the SLM
    whose coefficients are polynomials in wavelength, fitted linearly by least squares;
    products of field and wavelength terms above total degree ``field_degree + 1`` are
    left out.

    The series is in ``1/λ²`` by default: a lens's chromatic focal shift follows its
    glasses' index, close to a Cauchy ``A + B/λ²``, and a defocused spot's variance grows
    with the square of the shift, so the spot is a low-order polynomial there, and the
    red end, where ``1/λ²`` changes slowly, is not left to a series bending past the last
    line. Past the outermost lines the series continues linearly
    (``docs/notes/2026-11-30-singlet-snapshot-spectra.md`` compares the bases on the
    design rigs).

    Parameters
    ----------
    spots
        The measured moments (the line's own spectral width already taken out of ``cxx``).
    slm_shape
        SLM (height, width).
    pixel_variance_px2
        The SLM pixel image's variance inside the spot (kept with the model for its PSF).
    window_sigmas
        The model's summation window, in sigmas.
    field_degree
        Total degree of the field series.
    wavelength_degree
        Degree in wavelength; None: three less than the number of lines, from 1 to 3
        (the five lasers alone: 2, the defocus law of one glass in ``1/λ²``).
    wavelength_coordinate
        ``"inverse_square"`` (powers of a coordinate linear in ``1/λ²``) or
        ``"wavelength"`` (powers of ``λ``), see
        :func:`~sassi_bench.bundle.blur.field_covariance.wavelength_terms`.
    extrapolate_linearly
        Continue the series linearly past the outermost lines (the model's ``band_nm``);
        False: the polynomial everywhere.

    Returns
    -------
    BlurFit
        ``measured_sigma_px`` and ``residual_px`` per line: the median measured width
        across the streak and the model's median error there. ``relative_error`` is the
        RMS, relative to the widths, of each line's spots predicted by the fit to the
        other lines (capped at 0.5).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.uniform(0, 319, 200), rng.uniform(0, 199, 200)
    >>> lam = rng.choice([450.0, 520.0, 532.0, 635.0, 670.0], 200)
    >>> defocus = lambda lam: 2.0 * ((550.0 / lam) ** 2 - 1.0) ** 2  # quadratic in 1/λ²
    >>> cxx = 1.0 + 0.004 * u + defocus(lam)
    >>> cyy = 0.8 + 0.002 * v
    >>> cxy = 0.001 * (u - 160)
    >>> spots = SpotMoments(u, v, lam, cxx + 1 / 12, cyy + 1 / 12, cxy)
    >>> fit = fit_field_covariance(spots, (200, 320), 0.07, field_degree=2)
    >>> spot = fit.model.spot(300.0, 20.0, 600.0)
    >>> round(float(spot.along), 4) == round(float(np.sqrt(1 + 1.2 + defocus(600.0))), 4)
    True
    """
    lam = np.asarray(spots.wavelength_nm, dtype=np.float64)
    lines = np.unique(lam)
    if lines.size < 3:
        raise ProcedureError(
            step_error(
                "blur fit",
                f"only {lines.size} line(s) measured; the field blur needs three",
                "measure the blur under at least three laser lines",
            )
        )
    degree = min(3, max(1, lines.size - 3)) if wavelength_degree is None else int(wavelength_degree)
    band = (float(lines[0]), float(lines[-1])) if extrapolate_linearly else None

    def model(coeffs: NDArray[np.float64], error: float | None = None) -> FieldCovarianceBlur:
        return FieldCovarianceBlur(
            coeffs, field_degree, slm_shape, LAMBDA_REF_NM, LAMBDA_SCALE_NM, window_sigmas,
            pixel_variance_px2=pixel_variance_px2, relative_error=error,
            wavelength_coordinate=wavelength_coordinate, band_nm=band,
        )  # fmt: skip

    kept = _kept_terms(field_degree, degree)  # (F*L,)
    field_terms = kept.size // (degree + 1)
    design = _design(
        spots.u, spots.v, lam, slm_shape, field_degree, kept,
        lambda at: wavelength_terms(
            at, degree, LAMBDA_REF_NM, LAMBDA_SCALE_NM, wavelength_coordinate, band
        ),
    )  # fmt: skip
    pixel = CAMERA_PIXEL_VARIANCE_PX2
    targets = np.stack([spots.cxx - pixel, spots.cyy - pixel, spots.cxy], axis=1)  # (N, 3)

    def solve(rows: NDArray[np.bool_]) -> NDArray[np.float64]:
        coeffs = np.zeros((kept.size, 3))
        coeffs[kept] = np.linalg.lstsq(design[rows], targets[rows], rcond=None)[0]
        return coeffs.T.reshape(3, field_terms, degree + 1)

    everything = np.ones(lam.size, dtype=bool)
    fitted = model(solve(everything))
    width_sigma = _stated_width_sigma(fitted, design, kept, targets, lam, slm_shape)
    measured_across = np.sqrt(np.maximum(spots.cyy, 1e-6))
    error = None
    if lines.size >= 4:
        missed = []
        for line in lines:
            out = lam == line
            left = model(solve(~out))
            cyy = left.covariance(spots.u[out], spots.v[out], lam[out])[1]
            missed.append((np.sqrt(cyy + pixel) - measured_across[out]) / measured_across[out])
        error = min(float(np.sqrt(np.mean(np.concatenate(missed) ** 2))), 0.5)
    final = model(fitted.coeffs, error)
    predicted = np.sqrt(final.covariance(spots.u, spots.v, lam)[1] + pixel)
    medians = np.array([np.median(measured_across[lam == line]) for line in lines])
    residual = np.array([np.median((predicted - measured_across)[lam == line]) for line in lines])
    return BlurFit(final, lines, medians, residual, width_sigma)


def _design(
    u: ArrayLike,
    v: ArrayLike,
    wavelength_nm: NDArray[np.float64],
    slm_shape: tuple[int, int],
    field_degree: int,
    kept: NDArray[np.bool_],
    wavelength_terms_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
) -> NDArray[np.float64]:
    """The field blur's design matrix (N, kept terms): each kept product of a field term
    at (u, v) and a wavelength term at ``wavelength_nm``."""
    u_hat, v_hat = field_coordinates(u, v, slm_shape)
    field = legendre2d_design(u_hat, v_hat, field_degree)  # (N, F)
    powers = wavelength_terms_at(wavelength_nm)  # (N, L)
    return (field[:, :, None] * powers[:, None, :]).reshape(field.shape[0], -1)[:, kept]


def _kept_terms(field_degree: int, wavelength_degree: int) -> NDArray[np.bool_]:
    """Which (field term, wavelength power) products the field blur fits, flattened as its
    design's columns: those of total degree at most ``field_degree + 1``, so the whole
    field series may change linearly with wavelength and the higher powers only with its
    smoother terms (the full product fits the few blue lamp spots' scatter, see
    ``docs/notes/2026-11-30-singlet-snapshot-spectra.md``)."""
    field = np.array([a + b for a, b in legendre2d_terms(field_degree)])
    return (field[:, None] + np.arange(wavelength_degree + 1) <= field_degree + 1).ravel()


#: Field points (columns x rows) and wavelengths the stated width uncertainty is the worst
#: over: the SLM's edges and corners and the band between the outermost lines.
_STATED_GRID = (9, 5, 12)


def _stated_width_sigma(
    fitted: FieldCovarianceBlur,
    design: NDArray[np.float64],
    kept: NDArray[np.bool_],
    targets: NDArray[np.float64],
    wavelength_nm: NDArray[np.float64],
    slm_shape: tuple[int, int],
) -> float | None:
    """The worst 1-sigma (camera px) of the widths a camera would measure, as each line's
    residual scatter propagates through the fit's least squares to every field point and
    wavelength: where spots are sparse, or the fit extrapolates, the figure grows.

    Each spot's moments scatter as its own line's do (a dim lamp line's several times a
    laser's), so the variance of a prediction ``g·t`` (``g`` the row of the pseudo-inverse
    that makes it from the spots' moments ``t``) is ``Σ g_i² s²_line(i)``, not the pooled
    ``s² Σ g_i²`` that would let the bright lines' spots speak for the dim ones'. None
    when the fit has no degrees of freedom left.
    """
    rows, terms = design.shape
    if rows <= terms:
        return None
    left, singular, vt = np.linalg.svd(design, full_matrices=False)
    keep = singular > singular[0] * 1e-10  # rank-safe
    left, singular, vt = left[:, keep], singular[keep], vt[keep]
    residual = targets - left @ (left.T @ targets)
    # each line's variance from its residuals, each residual's expected square being
    # (1 - its leverage) of the variance: the fit takes up part of the scatter
    lines, line_of = np.unique(wavelength_nm, return_inverse=True)
    room = np.bincount(line_of, 1.0 - (left**2).sum(axis=1), minlength=lines.size)[:, None]
    squares = np.stack(
        [np.bincount(line_of, residual[:, k] ** 2, minlength=lines.size) for k in range(3)], 1
    )
    noise = (squares / np.maximum(room, 1e-9))[line_of]  # (N, 3) px**4
    h, w = slm_shape
    nu, nv, nl = _STATED_GRID
    u, v, lam = np.meshgrid(
        np.linspace(0, w - 1, nu), np.linspace(0, h - 1, nv), np.linspace(lines[0], lines[-1], nl)
    )
    u, v, lam = u.ravel(), v.ravel(), lam.ravel()
    points = _design(u, v, lam, slm_shape, fitted.field_degree, kept, fitted.wavelength_terms)
    gains = (points @ vt.T / singular) @ left.T  # the pseudo-inverse's rows, (points, N)
    variance = gains**2 @ noise  # (points, 3)
    cxx, cyy, _ = fitted.covariance(u, v, lam)
    along = np.sqrt(variance[:, 0]) / (2 * np.sqrt(cxx + CAMERA_PIXEL_VARIANCE_PX2))
    across = np.sqrt(variance[:, 1]) / (2 * np.sqrt(cyy + CAMERA_PIXEL_VARIANCE_PX2))
    return float(max(along.max(), across.max()))
