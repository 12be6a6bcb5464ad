"""The virtual bench's world state: scene, light, SLM pattern, and the optics."""

from __future__ import annotations

import hashlib

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.optics.psf import PsfSigmaCurve
from sassi_bench.optics.sensor import SensorModel
from sassi_bench.optics.sources import (
    SpectralSamples,
    coarser_samples,
    wavelength_grid,
)
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.lights import kind_of
from sassi_bench.rig.sim import as_built
from sassi_bench.rig.sim.design_render import DesignRenderer
from sassi_bench.rig.sim.drift import DriftModel, DriftState, drifted_relay
from sassi_bench.rig.sim.geometry import bench_relay
from sassi_bench.rig.sim.guide import GuideOptics
from sassi_bench.rig.sim.nuisance import BenchNuisances
from sassi_bench.rig.sim.render import SpectralRenderer
from sassi_bench.rig.sim.scenes import Scene, ScenePose, make_scene, posed_scene
from sassi_bench.rig.sim.sections import (
    as_built_section,
    check_bench_sections,
    nuisance_section,
)

__all__ = ["VirtualBench"]

# The closed-SLM background of a broadband light merges this many samples into one.
_BACKGROUND_EVERY = 2


def _either(true, described):
    """The as-built value where the rig gives one, else the described one."""
    return described if true is None else true


class VirtualBench:
    """Everything the simulated devices share.

    The SLM, cameras and light of a simulated rig are thin device facades over one
    ``VirtualBench``; the bench turns (scene, light, SLM pattern) into electron rates.

    Parameters
    ----------
    desc
        A validated rig description with ``backend: sim``.
    sparse_limit
        Patterns with at most this many open pixels are rendered by splatting streaks
        (exact), denser ones by warping (exact for extended patterns, within a few per
        cent per isolated pixel). ``None`` picks the break-even of the two costs, about
        one open pixel per 80 camera pixels.
    """

    def __init__(self, desc: RigDescription, sparse_limit: int | None = None) -> None:
        check_bench_sections(desc)
        self.description = desc
        self.slm_shape = (desc.slm.height, desc.slm.width)
        self.camera_shape = (desc.spectral_camera.height, desc.spectral_camera.width)
        g = desc.spectral_grid
        self.grid = wavelength_grid(g.start_nm, g.stop_nm, g.step_nm)
        true = as_built_section(desc)
        self.eps = 1.0 / _either(true.contrast_ratio, desc.slm.contrast_ratio)
        cam = desc.spectral_camera
        self.sensor = SensorModel(
            read_noise_e=_either(true.read_noise_e, cam.read_noise_e),
            full_well_e=_either(true.full_well_e, cam.full_well_e),
            bit_depth=cam.bit_depth,
            dark_offset_adu=cam.dark_offset_adu,
            dark_current_e_per_s=cam.dark_current_e_per_s,
            gain_e_per_adu=true.gain_e_per_adu,
            qe=_either(true.qe, cam.qe),
        )
        gc = desc.guide_camera
        self.guide_sensor = SensorModel(
            read_noise_e=gc.read_noise_e,
            full_well_e=gc.full_well_e,
            bit_depth=gc.bit_depth,
            dark_offset_adu=0.0 if gc.bit_depth <= 8 else 16.0,
            qe="flat",  # the colour sensitivities already include the sensor's QE
        )
        self.relay = bench_relay(desc)
        self._still_relay = self.relay
        nuisance = nuisance_section(desc)
        drift = nuisance.drift
        self.drift = DriftModel(drift, desc.seed) if drift is not None else None
        self.clock_h = drift.start_h if drift is not None else 0.0
        self._drift_state = DriftState()
        scale = _either(true.blur_scale, 1.0)
        self.blur = PsfSigmaCurve({k: scale * v for k, v in as_built.blur_sigma_px(desc).items()})
        fill_factor = _either(true.fill_factor, desc.slm.fill_factor)
        if desc.design is not None:  # spots from the traced design, as built
            self.renderer: SpectralRenderer = DesignRenderer(
                self.relay, fill_factor, self.sensor.quantum_efficiency
            )
        else:
            self.renderer = SpectralRenderer(
                self.relay, self.blur, fill_factor, self.sensor.quantum_efficiency
            )
        self.guide = GuideOptics(
            gc, self.slm_shape, self.grid, as_built.guide_sensitivities(desc, self.grid)
        )
        self.nuisance = BenchNuisances(nuisance, self.camera_shape, desc.seed, cam.full_well_e)
        self.scene_seed = int(np.random.SeedSequence([desc.seed, 2]).generate_state(1)[0])
        self._exposures_seen: dict[tuple[str, bytes], int] = {}
        self.sparse_limit = (
            sparse_limit
            if sparse_limit is not None
            else max(2000, self.slm_shape[0] * self.slm_shape[1] // 200)
        )
        self.lights = desc.light_names
        self.light = "off"
        self._transmission_lut: NDArray[np.float32] | None = None
        self.pattern = np.zeros(self.slm_shape, dtype=np.uint8)
        self._rate: tuple[bytes, NDArray[np.float32]] | None = None
        self._guide_rate: tuple[bytes, NDArray[np.float32]] | None = None
        self._scenes: dict[str, Scene] = {}
        self._samples: dict[str, SpectralSamples] = {}
        self._background: dict[tuple[str, ScenePose, str], NDArray[np.float32]] = {}
        self.pose = ScenePose()
        self.scene = self.scene_named("white")
        self._apply_drift()  # a bench opened later in the day starts drifted

    @property
    def pattern(self) -> NDArray[np.uint8]:
        """The pattern the SLM shows (uint8, SLM shape)."""
        return self._pattern

    @pattern.setter
    def pattern(self, pattern: NDArray[np.uint8]) -> None:
        self._pattern = pattern
        self._pattern_digest: bytes | None = None

    def pattern_digest(self) -> bytes:
        """A 16-byte digest of the pattern shown (computed once per pattern)."""
        if self._pattern_digest is None:
            digest = hashlib.blake2b(self._pattern.tobytes(), digest_size=16)
            self._pattern_digest = digest.digest()
        return self._pattern_digest

    def _state(self, *parts: str) -> bytes:
        """Digest of what the cameras see: light, scene, pose, and ``parts``."""
        digest = hashlib.blake2b(digest_size=16)
        for part in (self.light, self.scene.name, *parts):
            digest.update(part.encode() + b"\0")
        if not self.pose.is_identity:
            digest.update(repr((self.pose.shift_px, self.pose.rotation_deg)).encode() + b"\0")
        return digest.digest()

    # -- scene and light ----------------------------------------------------------------
    def scene_named(self, name: str) -> Scene:
        """Build (once) and return scene ``name``."""
        if name not in self._scenes:
            sc = self.description.scenes
            self._scenes[name] = make_scene(
                name,
                self.slm_shape,
                self.grid,
                sc.margin_px,
                seed=self.scene_seed,
                colorchecker_data=sc.colorchecker_data,
                colorchecker_rotation_deg=sc.colorchecker_rotation_deg,
                natural_image=sc.natural_image,
            )
        return self._scenes[name]

    def set_scene(self, name: str, pose: ScenePose | None = None) -> None:
        """Put scene ``name`` in front of the bench, moved to ``pose`` (default: static).

        Both cameras see the posed scene until the next call, so a moving scene is a
        pose set before each frame. Only the current posed scene is kept in memory.
        """
        self.pose = pose if pose is not None else ScenePose()
        if not self.pose.is_identity:
            stale = [k for k in self._background if k[1] != self.pose and not k[1].is_identity]
            for key in stale:
                del self._background[key]
        self.scene = posed_scene(self.scene_named(name), self.pose, self.slm_shape)

    def set_light(self, name: str) -> None:
        """Select light ``name`` (already validated by the light device)."""
        self.light = name

    def samples(self, light: str) -> SpectralSamples:
        """The spectral samples of light ``light``."""
        if light not in self._samples:
            try:
                kind = kind_of(light)
            except KeyError:  # pragma: no cover - the light device validates names
                raise ProcedureError(
                    step_error(
                        "light select",
                        f"unknown light {light!r}",
                        "select one of " + ", ".join(self.lights),
                    )
                ) from None
            settings = as_built.light_settings(
                self.description, light, kind.settings(light, self.description)
            )
            self._samples[light] = kind.samples(light, self.grid, settings)
        return self._samples[light]

    # -- noise ------------------------------------------------------------------------------
    def noise_rng(self, camera: str, exposure_s: float) -> np.random.Generator:
        """Random stream for the next frame of ``camera``, keyed by what it sees.

        The stream depends on the rig's seed, the camera, the state of the bench (pattern,
        light, scene, exposure) and how many frames of that same state this bench has
        exposed before; so a capture resumed on a freshly opened rig gets exactly the
        frames an uninterrupted one would have.
        """
        parts = [camera, repr(float(exposure_s))]
        if camera == "spectral":  # the guide camera does not see the SLM
            parts.append(self.pattern_digest().hex())
        state = self._state(*parts)
        key = (camera, state)
        count = self._exposures_seen.get(key, 0)
        self._exposures_seen[key] = count + 1
        words = np.frombuffer(state, dtype=np.uint32).tolist()
        return np.random.default_rng([self.description.seed, *words, count])

    # -- rendering ----------------------------------------------------------------------
    def transmission(self, pattern: NDArray[np.uint8]) -> NDArray[np.float32]:
        """SLM transmission for a uint8 pattern: eps + (1 - eps) (g / 255) ** gamma,
        with the SLM's true gamma."""
        if self._transmission_lut is None:
            # The same float32 arithmetic on the 256 levels, then looked up per pixel.
            levels = np.arange(256, dtype=np.float32)
            response = (levels / np.float32(255.0)) ** np.float32(
                as_built.slm_gamma(self.description)
            )
            self._transmission_lut = np.float32(self.eps) + np.float32(1.0 - self.eps) * response
        return self._transmission_lut[np.asarray(pattern, dtype=np.uint8)]

    def slm_transmission(self, pattern: NDArray[np.uint8]) -> NDArray[np.float32]:
        """The transmission the SLM really shows for ``pattern`` (with pixel crosstalk)."""
        transmission = self.transmission(pattern)
        if self.nuisance.config.slm_crosstalk <= 0:
            return transmission
        eps = np.float32(self.eps)
        return eps + self.nuisance.slm_excess(transmission - eps)

    def _background_rate(self) -> NDArray[np.float32]:
        """Light leaking through a fully closed SLM (cached per scene and light).

        A broadband light is rendered with each pair of neighbouring samples merged into
        one (:func:`~sassi_bench.optics.sources.coarser_samples`), for half the cost. The
        leak is ``1 / contrast`` of the light; at an exposure that fills pinhole streaks
        to 60 % of the well, the merged sum differs from the full one by 0.03 of the read
        noise RMS, at most 0.06 of the pixel's own noise (at sharp scene edges, where
        the coarser samples step the edge's dispersed image by two pixels).
        """
        key = (self.scene.name, self.pose, self.light)
        if key not in self._background:
            closed = np.full(self.slm_shape, np.float32(self.eps))
            samples = self.samples(self.light)
            if not kind_of(self.light).coherent:
                samples = coarser_samples(samples, _BACKGROUND_EVERY)
            self._background[key] = self.renderer.render_dense(closed, self.scene, samples)
        return self._background[key]

    def advance_clock(self, seconds: float) -> None:
        """Move the bench clock on by a spectral frame (its exposure plus the overhead) and
        the optics with it (``nuisance.drift``; a bench without drift holds still)."""
        if self.drift is None:
            return
        self.clock_h += (seconds + self.drift.config.frame_overhead_s) / 3600.0
        self._apply_drift()

    def set_clock(self, hours: float) -> None:
        """Set the bench clock (hours) and move the optics to their drift at that time."""
        self.clock_h = float(hours)
        self._apply_drift()

    def _apply_drift(self) -> None:
        if self.drift is None:
            return
        state = self.drift.state_at(self.clock_h)
        if state == self._drift_state:
            return
        self._drift_state = state
        self.relay = drifted_relay(self._still_relay, state)
        self.renderer.use_relay(self.relay)
        self._background.clear()
        self._rate = None

    def spectral_rate(self) -> NDArray[np.float32]:
        """Photo-electron rate on the spectral camera for the current state (e-/s).

        The last rate is kept (read-only) with the state it belongs to, so exposing the
        same state again (auto-exposure's trials, repeated frames) renders nothing.
        """
        self._apply_drift()
        state = self._state(self.pattern_digest().hex())
        if self._rate is None or self._rate[0] != state:
            rate = self._render_rate()
            rate.setflags(write=False)
            self._rate = (state, rate)
        return self._rate[1]

    def _render_rate(self) -> NDArray[np.float32]:
        samples = self.samples(self.light)
        if self.light == "off" or not np.any(samples.weights):
            return np.zeros(self.camera_shape, dtype=np.float32)
        if np.count_nonzero(self.pattern) > self.sparse_limit:
            return self.renderer.render_dense(
                self.slm_transmission(self.pattern), self.scene, samples
            )
        open_rows, open_cols = np.nonzero(self.pattern)
        excess = self.transmission(self.pattern[open_rows, open_cols]) - np.float32(self.eps)
        if self.nuisance.config.slm_crosstalk > 0:
            # Crosstalk lights the open pixels' neighbours: splat those too.
            image = np.zeros(self.slm_shape, dtype=np.float32)
            image[open_rows, open_cols] = excess
            image = self.nuisance.slm_excess(image)
            open_rows, open_cols = np.nonzero(image > 0)
            excess = image[open_rows, open_cols]
        return self.renderer.render_sparse(
            open_rows, open_cols, excess, self.scene, samples, base=self._background_rate()
        )

    def guide_rate(self) -> NDArray[np.float32]:
        """Photo-electron rate (H, W, 3) on the guide camera for the current state.

        Kept (read-only) with its state (light, scene, pose), like the spectral rate: a
        guide image averaged over frames renders once.
        """
        state = self._state()
        if self._guide_rate is None or self._guide_rate[0] != state:
            samples = self.samples(self.light)
            if self.light == "off":
                rate = np.zeros(self.guide.shape, dtype=np.float32)
            else:
                rate = self.guide.electron_rate(self.scene, samples.wavelengths_nm, samples.weights)
            rate.setflags(write=False)
            self._guide_rate = (state, rate)
        return self._guide_rate[1]
