"""Lamp-anchored wavelengths: one fit of the laser maps, the lamp streaks and the laser lines.

Laser maps alone fix the lasers' wavelengths only up to two numbers: the column is a
quadratic in the glass's spectral coordinate ``s(λ)`` at every field point, and any
``s -> α + βs`` is absorbed by the quadratic's coefficients, so laser lines off their
labels bend nothing the maps could see. Two or more atomic lamp lines at known
wavelengths fix ``α`` and ``β``. This module fits, in one least-squares problem:

* the column coefficients ``A`` of the dispersion model (``x = Σ_n Σ_t A_nt P_t(û, v̂)
  s(λ)^n``, as :mod:`sassi_bench.calibrate.dispersion`),
* every laser's true wavelength ``λ_l`` (its label as a prior of width
  ``tolerance_nm``),

against three kinds of data: every laser's smooth map sampled on a field grid (at
``λ_l``), every lamp pinhole's streak (:mod:`sassi_bench.calibrate.lamp_streaks`: each
listed line's spot at the column ``A`` puts its wavelength, line amplitudes shared by
every pinhole of the lamp, a gain and background per pinhole), and the priors. The
amplitudes, gains and backgrounds are linear: for each trial of ``(A, λ)`` they are
solved by alternating least squares (non-negative amplitudes), and Levenberg-Marquardt
steps ``(A, λ)`` with the normal equations built from analytic derivatives (the
Jacobian is never stored: its products are summed per pinhole).

Shared amplitudes matter: a blend's internal ratio trades against its centroid
pinhole by pinhole, but not when the lamp's spectrum is one for all pinholes and the
positions are tied to one smooth model.

The result's :class:`XInformation` is the lamp streaks' part of the normal equations
for ``A`` at the solution; :func:`~sassi_bench.calibrate.dispersion.fit_dispersion`
adds it to the maps' least squares, so the bundle's model and every leave-one-laser-out
refit keep the lamp lines as anchors.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from sassi_bench.bundle.blur import GAUSSIAN, GaussianProfile
from sassi_bench.calibrate.dispersion import BAND_NM, LAMBDA_REF_NM, LaserMap
from sassi_bench.calibrate.lamp_streaks import StreakProfiles, shared_line_amplitudes
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.optics.glass import Glass

__all__ = ["AnchoredWavelengths", "LampStreaks", "XInformation", "fit_anchored_wavelengths"]


@dataclass(frozen=True, eq=False)
class LampStreaks:
    """One lamp's data for the anchored fit.

    Attributes
    ----------
    name
        The lamp's name.
    lines_nm
        Wavelengths of the lines modelled (K,).
    start_intensity
        Their table intensities, where the amplitudes start (K,).
    psf_sigma_px
        The optics' PSF sigma at each line, camera px (K,).
    aperture_px
        Side of one SLM pixel's image on the camera, px.
    profiles
        The pinholes' streaks.
    spot
        The spot's profile (the bundle's blur's): a line's pixel-integrated spot.
    """

    name: str
    lines_nm: NDArray[np.float64]
    start_intensity: NDArray[np.float64]
    psf_sigma_px: NDArray[np.float64]
    aperture_px: float
    profiles: StreakProfiles
    spot: GaussianProfile = GAUSSIAN


@dataclass(frozen=True, eq=False)
class XInformation:
    """What the lamp streaks add to the column coefficients' normal equations, in map units.

    Minimising ``‖maps‖² + aᵀ matrix a − 2 aᵀ vector`` over the flattened column
    coefficients ``a`` (power-major, like ``DispersionModel.x_coeffs.ravel()``) is the
    anchored fit's least squares linearised at its solution.

    ``matrix`` is the lamps' Fisher information scaled by ``map_sigma_px²`` (the weight
    the maps' samples are given), so the lamps' photon noise moves the solution ``a`` of
    normal equations ``N`` (the maps' plus ``matrix``) by the covariance
    ``map_sigma_px² N⁻¹ matrix N⁻¹``.
    """

    matrix: NDArray[np.float64]
    vector: NDArray[np.float64]
    map_sigma_px: float = 1.0

    def noise_variance(self, solved: NDArray[np.float64]) -> NDArray[np.float64]:
        """Variance from the lamps' photon noise of linear functions ``r · a`` of the column
        coefficients, given ``solved = N⁻¹ rᵀ`` for each (one per row), ``N`` the full
        normal equations (the maps' plus :attr:`matrix`)."""
        return self.map_sigma_px**2 * np.einsum("ni,ij,nj->n", solved, self.matrix, solved)


@dataclass(frozen=True, eq=False)
class LampFit:
    """How one lamp's streaks fit.

    Attributes
    ----------
    amplitudes
        Fitted relative line amplitudes (strongest 1), as the camera sees them (K,).
    gains, backgrounds
        Per pinhole gain and background (P,), ADU.
    chi2
        Reduced chi-square of the streaks with the camera's noise (the fit scales each
        lamp's noise by it).
    line_shift_px, line_sigma_px
        Per line, the common shift (px) that would fit it best with every other line and
        the model held, and its 1-sigma uncertainty; NaN for lines too faint to tell.
    dispersion_px_per_nm
        Per line, the mean local dispersion over the pinholes.
    psf_coeffs
        The fitted PSF sigma, a cubic in ``(λ − 550) / 150``.
    """

    amplitudes: NDArray[np.float64]
    gains: NDArray[np.float64]
    backgrounds: NDArray[np.float64]
    chi2: float
    line_shift_px: NDArray[np.float64]
    line_sigma_px: NDArray[np.float64]
    dispersion_px_per_nm: NDArray[np.float64]
    psf_coeffs: NDArray[np.float64]

    def psf_sigma_px(self, wavelength_nm) -> NDArray[np.float64]:
        """The PSF sigma the lamp's spots were fitted with, camera px."""
        lam = np.atleast_1d(np.asarray(wavelength_nm, dtype=np.float64))
        return np.maximum(_psf_powers(lam) @ self.psf_coeffs, 0.05)

    @property
    def line_residual_nm(self) -> NDArray[np.float64]:
        """Per line, its residual in nm (shift over the local dispersion)."""
        return self.line_shift_px / self.dispersion_px_per_nm


@dataclass(frozen=True, eq=False)
class AnchoredWavelengths:
    """Result of :func:`fit_anchored_wavelengths`.

    Attributes
    ----------
    labels_nm, wavelengths_nm, sigma_nm
        Per laser: its label, its fitted wavelength and that wavelength's 1-sigma
        uncertainty (nm).
    x_coeffs
        The jointly fitted column coefficients (order + 1, terms).
    information
        The lamp streaks' normal equations for the column coefficients.
    lamps
        Per lamp name, how its streaks fit.
    map_rms_px
        RMS of the laser maps about the joint model.
    iterations
        Levenberg-Marquardt steps taken.
    """

    labels_nm: NDArray[np.float64]
    wavelengths_nm: NDArray[np.float64]
    sigma_nm: NDArray[np.float64]
    x_coeffs: NDArray[np.float64]
    information: XInformation
    lamps: dict[str, LampFit]
    map_rms_px: float
    iterations: int

    @property
    def by_label(self) -> dict[float, float]:
        """Label -> fitted wavelength (what ``fit_dispersion`` takes)."""
        return {
            float(k): float(w) for k, w in zip(self.labels_nm, self.wavelengths_nm, strict=True)
        }

    @property
    def sigma_by_label(self) -> dict[float, float]:
        """Label -> the fitted wavelength's 1-sigma (what ``fit_dispersion`` carries)."""
        return {float(k): float(s) for k, s in zip(self.labels_nm, self.sigma_nm, strict=True)}


class _Spectral:
    """The spectral coordinate ``s(λ) = (n(λ) − n(550)) / (n(400) − n(700))`` and powers."""

    def __init__(self, glass: Glass, order: int) -> None:
        self.glass = glass
        self.order = order
        self.n_ref = float(glass.index(LAMBDA_REF_NM))
        self.n_scale = float(glass.index(BAND_NM[0]) - glass.index(BAND_NM[1]))

    def s(self, lam: NDArray[np.float64]) -> NDArray[np.float64]:
        return (self.glass.index(np.asarray(lam, dtype=np.float64)) - self.n_ref) / self.n_scale

    def powers(self, lam: NDArray[np.float64]) -> NDArray[np.float64]:
        """``s^n`` (len(lam), order + 1)."""
        return self.s(lam)[:, None] ** np.arange(self.order + 1)[None, :]

    def power_slopes(self, lam: NDArray[np.float64]) -> NDArray[np.float64]:
        """``d(s^n)/dλ`` (len(lam), order + 1)."""
        step = 0.01
        ds = (self.s(lam + step) - self.s(lam - step)) / (2 * step)
        n = np.arange(self.order + 1)
        s = self.s(lam)[:, None]
        return np.where(n > 0, n * s ** np.maximum(n - 1, 0), 0.0) * ds[:, None]


#: The PSF sigma is a cubic in ``t = (λ − 550) / 150``, fitted with the lines (started at
#: the measured blur): a measured blur extrapolated to the band's ends can be well off
#: (``docs/notes/2026-12-01-measured-in-code-comments.md``), and spots of the wrong width
#: pull blended lines apart or together.
_BLUR_TERMS = 4
#: How far (px) the fitted PSF's terms may stray from the measured blur's (a weak prior).
_BLUR_PRIOR = 1.0
#: How tightly a lamp's amplitudes are held to their sum (the scale against the gains).
_SCALE_HOLD = 1e-6


def _psf_powers(wavelength_nm: NDArray[np.float64]) -> NDArray[np.float64]:
    """Powers of ``t = (λ − 550) / 150`` of the PSF's cubic (len, B)."""
    t = (np.asarray(wavelength_nm, dtype=np.float64) - LAMBDA_REF_NM) / 150.0
    return t[:, None] ** np.arange(_BLUR_TERMS)[None, :]


class _Lamp:
    """One lamp's streak model.

    ``m_pj = γ_p Σ_k α_k h(x_pj − X_pk; σ_k) + β_p``: line columns ``X`` from the column
    coefficients, spot widths ``σ`` from the blur terms, amplitudes ``α`` shared by the
    lamp's pinholes (their sum held at the table's, which fixes the scale against the
    gains), a gain ``γ_p`` and a background ``β_p`` per pinhole.
    """

    def __init__(self, data: LampStreaks, spectral: _Spectral, slm_shape, degree: int) -> None:
        p = data.profiles
        self.data = data
        self.field = legendre2d_design(*field_coordinates(p.u, p.v, slm_shape), degree)  # (P, T)
        self.line_powers = spectral.powers(data.lines_nm)  # (K, N)
        self.line_slopes = spectral.power_slopes(data.lines_nm)  # (K, N)
        self.blur_powers = _psf_powers(data.lines_nm)  # (K, B)
        self.blur_start = np.linalg.lstsq(self.blur_powers, data.psf_sigma_px, rcond=None)[0]
        self.weight = 1.0 / np.sqrt(np.maximum(p.variance, 1e-12))  # 0 where unusable
        self.start_amplitudes = data.start_intensity / data.start_intensity.max()
        self.total = float(self.start_amplitudes.sum())

    @property
    def lines(self) -> int:
        return int(self.data.lines_nm.size)

    def positions(self, coeffs: NDArray[np.float64]) -> NDArray[np.float64]:
        """Line columns (P, K)."""
        return (self.field @ coeffs.T) @ self.line_powers.T

    def sigmas(self, blur: NDArray[np.float64]) -> NDArray[np.float64]:
        """PSF sigma per line (K,)."""
        return np.maximum(self.blur_powers @ blur, 0.05)

    def spots(self, coeffs, blur, derivatives: bool = True):
        """Spot values (P, W, K) and, optionally, their derivatives in position and sigma.

        Only samples within 6 sigma (plus the pixel boxes) of a line are computed; the
        rest are zero to far below the noise.
        """
        offset = self.data.profiles.columns[:, :, None] - self.positions(coeffs)[:, None, :]
        sigma = self.sigmas(blur)
        near = np.abs(offset) < (6.0 * sigma + self.data.aperture_px + 1.0)[None, None, :]
        sigma_near = np.broadcast_to(sigma[None, None, :], offset.shape)[near]
        parts = self.data.spot.pixel_spot(offset[near], self.data.aperture_px, sigma_near)
        out = []
        for part in parts[: 3 if derivatives else 1]:
            full = np.zeros(offset.shape)
            full[near] = part
            out.append(full)
        return (out[0], None, None) if not derivatives else tuple(out)

    def start_linear(self, coeffs, blur, rounds: int = 10):
        """Amplitudes, gains and backgrounds for the start: alternating least squares
        (gain and background per pinhole, then non-negative shared amplitudes)."""
        spots, _, _ = self.spots(coeffs, blur, derivatives=False)
        y = self.data.profiles.profile
        w2 = self.weight**2
        amplitudes = self.start_amplitudes.copy()
        for _ in range(rounds):
            gains, backgrounds = self._gain_background(spots @ amplitudes, y, w2)
            scaled = spots * (gains[:, None] * self.weight)[:, :, None]  # (P, W, K)
            target = (y - backgrounds[:, None]) * self.weight
            amplitudes = shared_line_amplitudes(scaled, target)
            if amplitudes.sum() <= 0:
                raise ProcedureError(
                    step_error(
                        f"lamp lines {self.data.profiles.light}",
                        "none of the lamp's listed lines is in its streaks",
                        "check that the lamp's table lists its lines in air wavelengths (nm) "
                        "and that the right lamp is on",
                    )
                )
            amplitudes = amplitudes * (self.total / amplitudes.sum())
        gains, backgrounds = self._gain_background(spots @ amplitudes, y, w2)
        return amplitudes, gains, backgrounds

    @staticmethod
    def _gain_background(model, y, w2):
        a11, a12, a22 = (w2 * model * model).sum(1), (w2 * model).sum(1), w2.sum(1)
        b1, b2 = (w2 * model * y).sum(1), (w2 * y).sum(1)
        det = a11 * a22 - a12 * a12
        ok = det > 1e-12 * np.maximum(a11 * a22, 1e-300)
        safe = np.where(ok, det, 1.0)
        return (
            np.where(ok, (a22 * b1 - a12 * b2) / safe, 0.0),
            np.where(ok, (a11 * b2 - a12 * b1) / safe, 0.0),
        )

    def chi2(self, residual: NDArray[np.float64]) -> float:
        """Reduced chi-square of a weighted residual of this lamp's streaks."""
        used = int(np.count_nonzero(self.weight))
        dof = max(used - 2 * residual.shape[0] - self.lines, 1)
        return float((residual**2).sum() / dof)

    def residual(self, spots, amplitudes, gains, backgrounds) -> NDArray[np.float64]:
        """Weighted residual (P, W)."""
        model = gains[:, None] * (spots @ amplitudes) + backgrounds[:, None]
        return (model - self.data.profiles.profile) * self.weight


def _map_grid(maps: Sequence[LaserMap], slm_shape, degree: int, grid):
    h, w = slm_shape
    v, u = np.meshgrid(
        np.linspace(0, h - 1, grid[1]), np.linspace(0, w - 1, grid[0]), indexing="ij"
    )
    u, v = u.ravel(), v.ravel()
    field = legendre2d_design(*field_coordinates(u, v, slm_shape), degree)
    return field, np.stack([m.x(u, v) for m in maps])


@dataclass
class _State:
    """Parameters of the anchored fit and everything evaluated at them."""

    globals_: NDArray[np.float64]  # [A (power-major), λ, blur, α of each lamp]
    gains: list[NDArray[np.float64]]  # per lamp, (P,)
    backgrounds: list[NDArray[np.float64]]
    cost: float = np.inf
    normal: NDArray[np.float64] | None = None  # Schur complement: the globals' normal matrix
    gradient: NDArray[np.float64] | None = None
    lamp_normal: NDArray[np.float64] | None = None  # the lamps' part of ``normal``
    lamp_gradient: NDArray[np.float64] | None = None
    locals_: list[tuple] | None = None  # per lamp: V⁻¹, W, local gradient
    residuals: list[NDArray[np.float64]] | None = None
    line_terms: list[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None


class _Problem:
    """The anchored least squares, solved by Gauss-Newton with the per-pinhole gains and
    backgrounds eliminated (a Schur complement, as in bundle adjustment)."""

    def __init__(self, maps, lamps, glass, slm_shape, tolerance_nm, degree, order, grid, sigma):
        self.spectral = _Spectral(glass, order)
        self.labels = np.array([m.wavelength_nm for m in maps], dtype=np.float64)
        self.tau = np.asarray(tolerance_nm, dtype=np.float64)
        self.field, self.xs = _map_grid(maps, slm_shape, degree, grid)
        self.order = order
        self.n_coeffs = (order + 1) * self.field.shape[1]
        self.lamps = [_Lamp(lamp, self.spectral, slm_shape, degree) for lamp in lamps]
        self.sigma = sigma
        self.field_normal = self.field.T @ self.field
        n, lasers = self.n_coeffs, self.labels.size
        self.lasers = slice(n, n + lasers)
        # Each lamp's own unknowns: its spot width (a cubic started at the measured
        # blur) and its line amplitudes. The spot width is the lamp's: a lamp's spots are
        # a little wider or narrower than the lasers' (its lines' own width, its place
        # on the diffuser), and one compromise width would pull blends one way.
        self.blurs, self.amplitudes = [], []
        first = n + lasers
        for lamp in self.lamps:
            self.blurs.append(slice(first, first + _BLUR_TERMS))
            self.amplitudes.append(slice(first + _BLUR_TERMS, first + _BLUR_TERMS + lamp.lines))
            first += _BLUR_TERMS + lamp.lines
        self.size = first

    def coeffs(self, globals_):
        return globals_[: self.n_coeffs].reshape(self.order + 1, -1)

    def start(self, powers_used: int | None = None) -> _State:
        """The fit's start: the column model through the laser maps at the labels, with
        its first ``powers_used`` spectral powers (None: all), the lamps' linear unknowns
        solved for it."""
        used = self.order + 1 if powers_used is None else min(powers_used, self.order + 1)
        powers = self.spectral.powers(self.labels)[:, :used]
        coeffs = np.zeros((self.order + 1, self.field.shape[1]))
        coeffs[:used] = np.linalg.pinv(powers) @ self.xs @ np.linalg.pinv(self.field).T
        parts = [coeffs.ravel(), self.labels]
        gains, backgrounds = [], []
        for lamp in self.lamps:
            amplitudes, gain, background = lamp.start_linear(coeffs, lamp.blur_start)
            parts += [lamp.blur_start, amplitudes]
            gains.append(gain)
            backgrounds.append(background)
        return self.evaluate(_State(np.concatenate(parts), gains, backgrounds))

    def _maps(self, globals_, jtj, jtr) -> float:
        """The laser maps' and the priors' terms; returns their cost."""
        n, sigma = self.n_coeffs, self.sigma
        coeffs, lam = self.coeffs(globals_), globals_[self.lasers]
        powers = self.spectral.powers(lam)  # (L, N)
        per_point = coeffs @ self.field.T  # (N, G)
        r_map = (powers @ per_point - self.xs) / sigma  # (L, G)
        d_lam = (self.spectral.power_slopes(lam) @ per_point) / sigma  # d r_map[l] / d λ_l
        r_prior = (lam - self.labels) / self.tau
        jtj[:n, :n] += np.kron(powers.T @ powers, self.field_normal) / sigma**2
        jtr[:n] += np.einsum("ln,lg,gt->nt", powers, r_map, self.field).ravel() / sigma
        cross = np.einsum("ln,lg,gt->ntl", powers, d_lam, self.field).reshape(n, -1) / sigma
        jtj[:n, self.lasers] += cross
        jtj[self.lasers, :n] += cross.T
        jtj[self.lasers, self.lasers] += np.diag((d_lam**2).sum(1) + 1.0 / self.tau**2)
        jtr[self.lasers] += (d_lam * r_map).sum(1) + r_prior / self.tau
        cost = float((r_map**2).sum() + (r_prior**2).sum())
        for lamp, blur, at in zip(self.lamps, self.blurs, self.amplitudes, strict=True):
            r_blur = (globals_[blur] - lamp.blur_start) / _BLUR_PRIOR
            jtj[blur, blur] += np.eye(_BLUR_TERMS) / _BLUR_PRIOR**2
            jtr[blur] += r_blur / _BLUR_PRIOR
            cost += float((r_blur**2).sum())
            # The scale against the gains: the amplitudes sum to the table's.
            r_sum = (globals_[at].sum() - lamp.total) / _SCALE_HOLD
            jtj[at, at] += 1.0 / _SCALE_HOLD**2
            jtr[at] += r_sum / _SCALE_HOLD
            cost += r_sum**2
        return cost

    def evaluate(self, state: _State) -> _State:
        """Cost, and the globals' normal equations with the locals eliminated.

        A lamp's Jacobian in the column coefficients is, at every sample of pinhole p,
        ``m ⊗ F_p`` (the line positions' derivatives ``m`` through the spectral powers,
        times the pinhole's field basis ``F_p``), and its gain and background are the
        pinhole's alone. So every product the normal equations need is a small Gram
        matrix per pinhole of ``[m, blur and amplitude derivatives, local derivatives,
        residual]`` over its samples, from which the locals are eliminated pinhole by
        pinhole (a 2 x 2 Schur complement) before the field basis is put back in: an
        evaluation costs ``samples x (N + blur + lines + 3)²`` rather than
        ``samples x (N x terms + blur + lines)²``, and the Jacobian is never formed.
        """
        g = state.globals_
        coeffs = self.coeffs(g)
        jtj = np.zeros((self.size, self.size))
        jtr = np.zeros(self.size)
        cost = self._maps(g, jtj, jtr)
        lamp_normal = np.zeros_like(jtj)
        lamp_gradient = np.zeros_like(jtr)
        locals_, residuals, lines = [], [], []
        n, powers = self.n_coeffs, self.order + 1
        for i, lamp in enumerate(self.lamps):
            amplitudes = g[self.amplitudes[i]]
            gains, backgrounds = state.gains[i], state.backgrounds[i]
            blur = g[self.blurs[i]]
            spots, slopes, widths = lamp.spots(coeffs, blur)
            r = lamp.residual(spots, amplitudes, gains, backgrounds)
            w = lamp.weight
            scale = gains[:, None, None] * w[:, :, None]  # (P, W, 1)
            d_pos = -scale * slopes * amplitudes  # d r / d X (P, W, K)
            # Per line: the residual along its position derivative, and that derivative's
            # square (the lamp's per-line shifts at the solution).
            lines.append((np.einsum("pjk,pj->k", d_pos, r), np.einsum("pjk,pjk->k", d_pos, d_pos)))
            samples = np.concatenate(
                [
                    d_pos @ lamp.line_powers,  # m (P, W, N)
                    (scale * widths * amplitudes) @ lamp.blur_powers,  # blur (P, W, B)
                    scale * spots,  # amplitudes (P, W, K)
                    (w * (spots @ amplitudes))[:, :, None],  # d r / d gain
                    w[:, :, None],  # d r / d background
                    r[:, :, None],
                ],
                axis=2,
            )
            gram = np.matmul(samples.transpose(0, 2, 1), samples)  # (P, L, L)
            del samples, d_pos
            other = slice(powers, gram.shape[1] - 3)  # blur and amplitudes
            local, last = slice(gram.shape[1] - 3, gram.shape[1] - 1), gram.shape[1] - 1
            v_inv = np.linalg.pinv(gram[:, local, local])  # (P, 2, 2)
            to_local = gram[:, :, local]  # (P, L, 2)
            reduced = gram - to_local @ v_inv @ to_local.transpose(0, 2, 1)
            field = lamp.field  # (P, T)
            m = slice(0, powers)
            rest = gram.shape[1] - 3 - powers
            block = np.empty((n + rest, n + rest))
            block[:n, :n] = np.einsum(
                "pab,pt,pu->atbu", reduced[:, m, m], field, field, optimize=True
            ).reshape(n, n)
            block[:n, n:] = np.einsum("pae,pt->ate", reduced[:, m, other], field).reshape(n, -1)
            block[n:, :n] = block[:n, n:].T
            block[n:, n:] = reduced[:, other, other].sum(axis=0)
            grad = np.concatenate(
                [
                    np.einsum("pa,pt->at", reduced[:, m, last], field).ravel(),
                    reduced[:, other, last].sum(axis=0),
                ]
            )
            index = np.r_[np.arange(n), np.arange(self.blurs[i].start, self.amplitudes[i].stop)]
            lamp_normal[np.ix_(index, index)] += block
            lamp_gradient[index] += grad
            cost += float((r**2).sum())
            local_gradient = gram[:, local, last]  # (P, 2)
            locals_.append(
                (index, v_inv, gram[:, local, m], gram[:, local, other], field, local_gradient)
            )
            residuals.append(r)
        state.cost = cost
        state.normal = jtj + lamp_normal
        state.gradient = jtr + lamp_gradient
        state.lamp_normal, state.lamp_gradient = lamp_normal, lamp_gradient
        state.locals_, state.residuals, state.line_terms = locals_, residuals, lines
        return state

    def step(self, state: _State, damping: float) -> _State:
        """A damped Gauss-Newton step; amplitudes kept non-negative."""
        normal = state.normal + damping * np.diag(np.diag(state.normal))
        amplitudes = np.zeros(self.size, dtype=bool)
        for at in self.amplitudes:
            amplitudes[at] = True
        # Amplitudes the step would make negative are set to zero and the step solved again
        # for the rest (an active set: a line absent from the lamp stays at zero).
        delta = np.zeros(self.size)
        held = np.zeros(self.size, dtype=bool)
        for _ in range(20):
            free = ~held
            rhs = state.gradient[free] - normal[np.ix_(free, held)] @ delta[held]
            delta[free] = np.linalg.solve(normal[np.ix_(free, free)], rhs)
            negative = amplitudes & ~held & (state.globals_ - delta < 0)
            if not negative.any():
                break
            held |= negative
            delta[negative] = state.globals_[negative]
        g = state.globals_ - delta
        gains, backgrounds = [], []
        n = self.n_coeffs
        for i, (index, v_inv, local_m, local_other, field, local_gradient) in enumerate(
            state.locals_
        ):
            step = delta[index]
            # The locals' share of the step: their gradient less the globals' step seen
            # through each pinhole's cross terms (coefficients through its field basis).
            coeff_step = field @ step[:n].reshape(self.order + 1, -1).T  # (P, N)
            seen = np.einsum("pan,pn->pa", local_m, coeff_step) + local_other @ step[n:]
            d_local = np.einsum("pab,pb->pa", v_inv, local_gradient - seen)
            gains.append(state.gains[i] - d_local[:, 0])
            backgrounds.append(state.backgrounds[i] - d_local[:, 1])
        return self.evaluate(_State(g, gains, backgrounds))

    def laser_sigma(self, state: _State) -> NDArray[np.float64]:
        """1-sigma uncertainty of the lasers' wavelengths (nm), scaled by the lamps' reduced
        chi-square; amplitudes at their bound (zero: a line absent from the lamp) are held."""
        g = state.globals_
        free = np.ones(self.size, dtype=bool)
        for at in self.amplitudes:
            free[at] = g[at] > 1e-6 * g[at].max()
        # The lasers' block of the inverse, by eliminating every other unknown (a Schur
        # complement): lines of a lamp that fall on the same pixels (a blend at the red
        # end) share one column and only their sum is known, which leaves the whole
        # normal matrix singular, but not the lasers' part; any generalised inverse of
        # the rest gives the same complement.
        lasers = np.zeros(self.size, dtype=bool)
        lasers[self.lasers] = True
        rest = free & ~lasers
        normal = state.normal
        cross = normal[np.ix_(lasers, rest)]
        reduced = (
            normal[np.ix_(lasers, lasers)]
            - cross @ np.linalg.pinv(normal[np.ix_(rest, rest)], hermitian=True) @ cross.T
        )
        chi2 = max(lamp.chi2(r) for lamp, r in zip(self.lamps, state.residuals, strict=True))
        variance = np.diag(np.linalg.inv(reduced)) * max(chi2, 1.0)
        return np.sqrt(np.clip(variance, 0.0, None))

    def information(self, state: _State, sigma: float) -> XInformation:
        """The lamps' normal equations for the column coefficients, their other unknowns
        (blur, amplitudes) eliminated, in map units, linearised at ``state``."""
        n = self.n_coeffs
        rest = np.arange(self.lasers.stop, self.size)
        held = np.zeros((self.size, self.size))
        gradient = state.lamp_gradient.copy()
        for lamp, blur, at in zip(self.lamps, self.blurs, self.amplitudes, strict=True):
            held[blur, blur] = np.eye(_BLUR_TERMS) / _BLUR_PRIOR**2
            gradient[blur] += (state.globals_[blur] - lamp.blur_start) / _BLUR_PRIOR**2
            held[at, at] = 1.0 / _SCALE_HOLD**2
            gradient[at] += (state.globals_[at].sum() - lamp.total) / _SCALE_HOLD**2
        normal = state.lamp_normal + held
        solve = np.linalg.pinv(normal[np.ix_(rest, rest)])
        matrix = normal[:n, :n] - normal[:n, rest] @ solve @ normal[rest, :n]
        reduced = gradient[:n] - normal[:n, rest] @ solve @ gradient[rest]
        coeffs = state.globals_[:n]
        return XInformation(sigma**2 * matrix, sigma**2 * (matrix @ coeffs - reduced), sigma)


def _solve(problem: _Problem, state: _State, max_iterations: int) -> tuple[_State, int]:
    """Levenberg-Marquardt steps until the lasers' wavelengths settle (to 0.001 nm).

    The damping starts small and goes to nothing while steps succeed: the amplitudes'
    sum prior (1e12 on their diagonal) makes any Marquardt damping of a few 1e-5 a brake
    on the weak lines, under which steps shrink until they pass for settled short of the
    minimum (``docs/notes/2026-12-01-measured-in-code-comments.md``). A step that raises
    the cost is retried with ten times the damping."""
    damping = 1e-9
    iterations = 0
    for iterations in range(1, max_iterations + 1):  # noqa: B007 - reported
        trial = problem.step(state, damping)
        if trial.cost <= state.cost:
            moved = np.abs(trial.globals_[problem.lasers] - state.globals_[problem.lasers]).max()
            settled = moved < 1e-3 and state.cost - trial.cost <= 1e-6 * state.cost
            state = trial
            damping = max(damping / 10.0, 1e-15)
            if settled:
                break
        else:
            damping *= 10.0
            if damping > 1e6:
                break
    return state, iterations


def fit_anchored_wavelengths(
    maps: Sequence[LaserMap],
    lamps: Sequence[LampStreaks],
    glass: Glass,
    slm_shape: tuple[int, int],
    tolerance_nm: Sequence[float],
    *,
    field_degree: int = 5,
    order: int = 2,
    grid: tuple[int, int] = (33, 21),
    map_sigma_px: float = 0.01,
    max_iterations: int = 50,
) -> AnchoredWavelengths:
    """Fit the column model and every laser's wavelength to laser maps and lamp streaks.

    Parameters
    ----------
    maps
        One map per laser, labelled with the laser's nominal wavelength.
    lamps
        The lamps' streaks (at least one lamp).
    glass
        The prism's catalogue glass.
    slm_shape
        SLM (height, width).
    tolerance_nm
        Per laser, how far its true line may be from its label (the prior's sigma).
    field_degree, order, grid
        As for :func:`~sassi_bench.calibrate.dispersion.fit_dispersion`.
    map_sigma_px
        Uncertainty of a laser map's sampled column, camera px.
    max_iterations
        Gauss-Newton steps at most.

    Returns
    -------
    AnchoredWavelengths

    Examples
    --------
    Not run here (it needs measured frames)::

        fit = fit_anchored_wavelengths(maps, lamps, get_glass("N-BK7"), (400, 640),
                                       [5.0] * len(maps))
        fit.by_label
        # {450.0: 454.61, 520.0: 516.19, 532.0: 532.0, 635.0: 639.1, 670.0: 665.31}
    """
    problem = _Problem(
        maps, lamps, glass, slm_shape, tolerance_nm, field_degree, order, grid, map_sigma_px
    )
    # Small dense systems: threaded BLAS only adds contention.
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit(problem, max_iterations, map_sigma_px)


#: The spectral powers of the stiff start (:func:`_fit`): a straight line in ``s(λ)``.
_STIFF_START_POWERS = 2


def _fit(problem: _Problem, max_iterations: int, map_sigma_px: float) -> AnchoredWavelengths:
    # Two starts, the lower cost kept. The column model through the maps at the labels
    # bends with the labels' errors: two lasers close in wavelength with one of them a
    # few nm off its label give a curvature that puts the lamp lines at the band's ends
    # several nm from where they are, and the fit settles with lamp lines taken for their
    # neighbours (docs/notes/2026-11-30-rig-family-lamps.md). A straight line in s(λ)
    # through the maps cannot bend that way.
    starts = [problem.start()]
    if problem.order + 1 > _STIFF_START_POWERS:
        starts.append(problem.start(_STIFF_START_POWERS))
    solved = [_solve(problem, start, max_iterations) for start in starts]
    state = min(solved, key=lambda pair: pair[0].cost)[0]
    iterations = sum(count for _, count in solved)
    # Each lamp's noise scaled to its reduced chi-square (the spot model is never exact,
    # least of all for a bright lamp), then the fit finished with those weights.
    noise = []
    for lamp, residual in zip(problem.lamps, state.residuals, strict=True):
        noise.append(max(lamp.chi2(residual), 1.0))
        lamp.weight = lamp.weight / np.sqrt(noise[-1])
    state, more = _solve(problem, problem.evaluate(state), max_iterations)
    iterations += more
    g = state.globals_
    coeffs, lam = problem.coeffs(g), g[problem.lasers]
    lamp_fits = {
        lamp.data.name: _lamp_fit(
            lamp, coeffs, g[at], g[blur], (gains, backgrounds), r, terms, scale
        )
        for lamp, at, blur, gains, backgrounds, r, terms, scale in zip(
            problem.lamps,
            problem.amplitudes,
            problem.blurs,
            state.gains,
            state.backgrounds,
            state.residuals,
            state.line_terms,
            noise,
            strict=True,
        )
    }
    sigma_nm = problem.laser_sigma(state)
    per_point = coeffs @ problem.field.T
    map_rms = float(np.sqrt(np.mean((problem.spectral.powers(lam) @ per_point - problem.xs) ** 2)))
    return AnchoredWavelengths(
        labels_nm=problem.labels,
        wavelengths_nm=lam.copy(),
        sigma_nm=sigma_nm,
        x_coeffs=coeffs.copy(),
        information=problem.information(state, map_sigma_px),
        lamps=lamp_fits,
        map_rms_px=map_rms,
        iterations=iterations,
    )


def _lamp_fit(lamp: _Lamp, coeffs, amplitudes, blur, locals_, residual, terms, noise) -> LampFit:
    """Per-line shifts at the solution (one Gauss-Newton step per line, the rest held);
    ``terms`` are each line's residual along its position derivative and that
    derivative's square; ``noise`` is the factor the lamp's variance was scaled by."""
    chi2 = lamp.chi2(residual)
    along, curvature = terms
    visible = (curvature > 0) & (amplitudes >= 0.05 * amplitudes.max())
    safe = np.where(visible, curvature, 1.0)
    shift = np.where(visible, -along / safe, np.nan)
    sigma = np.where(visible, np.sqrt(max(chi2, 1.0) / safe), np.nan)
    slopes = (lamp.field @ coeffs.T) @ lamp.line_slopes.T  # (P, K) dx/dλ
    peak = amplitudes.max()
    return LampFit(
        amplitudes=amplitudes / peak,
        gains=locals_[0] * peak,
        backgrounds=locals_[1],
        psf_coeffs=blur.copy(),
        chi2=chi2 * noise,
        line_shift_px=shift,
        line_sigma_px=sigma,
        dispersion_px_per_nm=slopes.mean(axis=0),
    )
