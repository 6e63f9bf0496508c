"""Scenes: the radar, its targets and its attackers as one immutable, validated value.

Scenes are loaded from TOML files and presets by :mod:`carav_stream.radar.scene_loader`, which validates every
key against its declaration and reports every problem at once in one :class:`SceneError`. Physics that is
legal but probably not what the user meant (a beat beyond the ADC's Nyquist rate, a Doppler beyond the
unambiguous velocity, an attacker that saturates the ADC) goes to ``Scene.warnings``.

Conventions
    * Target ``velocity_mps`` is the target's ground speed along the radar's boresight, positive in
      the radar's direction of travel (away from the radar); the radar moves at ``radar_speed_mps``.
      The range rate is ``velocity_mps - radar_speed_mps`` (Table I: 96 - 100 km/h, closing).
    * Geometry is frozen per cycle: every cycle starts from the scene's ranges (stationary statistics,
      as in the paper's Monte Carlo runs); motion within a cycle is modelled (Doppler, migration).
    * Samples are in sqrt(W) at the receiver output (1 ohm), after the receive gain.
    * ``sigma_n`` is the per-sample noise RMS at the ADC input, E|n|^2 = sigma_n^2, for I-only and I/Q
      alike. An I-only receiver is the I branch of the I/Q one: it sees half the echo power and half
      the noise power, so the per-sample SNR is the same in both modes.
    * Noise level, first match wins: ``sigma_n`` (explicit), ``snr_db`` (per-sample SNR of the first
      target), else the radar equation: k T fs F G_rx (noise bandwidth = sample rate).
    * The ADC starts ``t_adc_start_s`` after the chirp's start, where the ramp resets. A scene that does not say
      when starts IF_SETTLE_SAMPLES / fs in (``adc_start_default``): at the reset the reference jumps by the
      whole bandwidth and the previous chirp's echo, in band until then, leaves the band at once; the IF filter
      spreads that cut over its impulse response, IF_SETTLE_SAMPLES samples either side, so samples taken before
      it has settled carry a share of that echo into every silent slot after an active one (docs/DETECTION.md,
      "Near echoes in the silent slots"). The table1 preset starts there too; real radars wait for the synthesiser
      and the IF filter to settle (TI's adcStartTime, 7 us in the awr1642 preset). 0 samples from the reset, as
      MATLAB's example does, when a scene says so.
    * Arrays (docs/SCENES.md, "Receiver arrays"): antenna positions along one axis in wavelengths; a path from
      azimuth theta reaches an element at x wavelengths with the phase exp(+j 2 pi x sin theta) relative to x = 0
      (theta > 0 towards larger x). Chirp slot k of a cycle is fired by transmitter ``tdm_schedule[k % n_slots]``;
      an echo goes out from that transmitter and back to every receiver (the virtual element at tx + rx), an
      attacker's signal only reaches the receivers (one way). A scene with one receiver and one slot is exactly
      the single-antenna radar of the paper: frames keep the shape (cycles, chirps, samples) and every output is
      the same; with several receivers frames carry a receiver axis, (cycles, receivers, chirps, samples).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from carav_stream.core.arrays import virtual_positions
from carav_stream.core.units import C_MPS

IF_SETTLE_SAMPLES = 16     # the IF filter's half length in ADC samples (the waveform fidelity's FIR: 32 samples long)


class SceneError(ValueError):
    """All problems of a scene, one located message per line (``problems`` holds them)."""

    def __init__(self, problems: list[str]):
        self.problems = list(problems)
        super().__init__("invalid scene:\n  " + "\n  ".join(self.problems))


@dataclass(frozen=True)
class Target:
    """A point target. ``velocity_mps`` is its ground speed along boresight (+ = away)."""

    range_m: float
    velocity_mps: float = 0.0
    rcs_m2: float = 1.0
    swerling: int = 0
    azimuth_deg: float = 0.0


@dataclass(frozen=True)
class AttackerSpec:
    """An attacker as written in a scene: its kind, its parameters (name, value) pairs, and the azimuth its antenna
    is seen at from the radar (what a receiver array can measure)."""

    kind: str
    params: tuple[tuple[str, Any], ...] = ()
    azimuth_deg: float = 0.0

    def kwargs(self) -> dict[str, Any]:
        return dict(self.params)


@dataclass(frozen=True)
class Scene:
    """A validated scene. Frozen and hashable, so derived arrays can be cached per scene."""

    name: str
    fc_hz: float
    bandwidth_hz: float
    t_sweep_s: float
    t_chirp_s: float
    t_cycle_s: float
    t_adc_start_s: float
    fs_hz: float
    n_chirps: int
    n_samples: int
    iq: bool
    adc_bits: int
    adc_full_scale: float
    tx_power_w: float
    tx_gain_db: float
    rx_gain_db: float
    noise_figure_db: float
    temperature_k: float
    sigma_n: float
    radar_speed_mps: float
    targets: tuple[Target, ...] = ()
    attackers: tuple[AttackerSpec, ...] = ()
    waveform_oversample: int = 4
    if_filter: bool = True
    tx_positions_wl: tuple[float, ...] = (0.0,)
    rx_positions_wl: tuple[float, ...] = (0.0,)
    tdm_schedule: tuple[int, ...] = (0,)
    warnings: tuple[str, ...] = ()
    description: str = ""
    source: str = field(default="", compare=False)
    adc_start_default: bool = field(default=False, compare=False)    # t_adc_start_s was not given: the settled one

    @property
    def slope_hz_per_s(self) -> float:
        return self.bandwidth_hz / self.t_sweep_s

    @property
    def wavelength_m(self) -> float:
        return C_MPS / self.fc_hz

    @property
    def range_resolution_m(self) -> float:
        """c / (2 B_sampled), B_sampled the bandwidth swept during the sampling window."""
        return C_MPS / (2.0 * self.slope_hz_per_s * self.n_samples / self.fs_hz)

    @property
    def max_beat_hz(self) -> float:
        """Highest representable beat: fs for complex (I/Q) sampling, fs/2 for real (I-only)."""
        return self.fs_hz if self.iq else self.fs_hz / 2.0

    @property
    def max_range_m(self) -> float:
        """Range whose beat reaches ``max_beat_hz`` (Doppler ignored)."""
        return self.max_beat_hz * C_MPS / (2.0 * self.slope_hz_per_s)

    @property
    def max_velocity_mps(self) -> float:
        """Unambiguous |range rate|: lambda / (4 T), T the repetition of one transmitter (t_chirp times the TDM
        loop's slots; t_chirp for a single transmitter)."""
        return self.wavelength_m / (4.0 * self.t_loop_s)

    @property
    def n_rx(self) -> int:
        return len(self.rx_positions_wl)

    @property
    def n_tx(self) -> int:
        return len(self.tx_positions_wl)

    @property
    def n_slots(self) -> int:
        """Chirp slots in one TDM loop (every transmitter of the schedule fires once per loop)."""
        return len(self.tdm_schedule)

    @property
    def n_loops(self) -> int:
        return self.n_chirps // self.n_slots

    @property
    def t_loop_s(self) -> float:
        """Repetition interval of one transmitter: a whole TDM loop."""
        return self.n_slots * self.t_chirp_s

    @property
    def has_array(self) -> bool:
        return self.n_rx > 1 or self.n_slots > 1

    @property
    def virtual_positions_wl(self) -> np.ndarray:
        """float64 (n_slots * n_rx,): the virtual array, slot-major: tx_positions_wl[tdm_schedule[j]] + rx r."""
        return virtual_positions(self.tx_positions_wl, self.rx_positions_wl, self.tdm_schedule)

    def frame_shape(self, n_cycles: int) -> tuple[int, ...]:
        """Shape of the ADC frames of n_cycles cycles: a receiver axis only when there is more than one receiver."""
        if self.n_rx > 1:
            return (n_cycles, self.n_rx, self.n_chirps, self.n_samples)
        return (n_cycles, self.n_chirps, self.n_samples)

    @property
    def cycles_per_s(self) -> float:
        return 1.0 / self.t_cycle_s

    def range_rate_mps(self, target: Target) -> float:
        return target.velocity_mps - self.radar_speed_mps

    def beat_hz(self, target: Target) -> float:
        """Beat of ``target`` at chirp 0: S tau - f_D (MATLAB dechirp convention, f_D > 0 closing)."""
        tau_s = 2.0 * target.range_m / C_MPS
        return self.slope_hz_per_s * tau_s + 2.0 * self.range_rate_mps(target) / self.wavelength_m

    def echo_power_w(self, target: Target) -> float:
        """Mean per-sample echo power at the ADC input (radar equation, two-way free space).

        Pt Gt Grx sigma lambda^2 / ((4 pi)^3 R^4), halved for I-only (the I branch sees half).
        """
        p_w = (self.tx_power_w * 10 ** (self.tx_gain_db / 10) * 10 ** (self.rx_gain_db / 10)
               * target.rcs_m2 * self.wavelength_m ** 2 / ((4 * math.pi) ** 3 * target.range_m ** 4))
        return p_w if self.iq else p_w / 2.0

    def snr_db(self, target_index: int = 0) -> float:
        """Per-sample SNR of a target, in dB (same for I-only and I/Q)."""
        return 10 * math.log10(self.echo_power_w(self.targets[target_index]) / self.sigma_n ** 2)


def target_warnings(scene: Scene) -> list[str]:
    """Legal but suspicious physics of the radar and its targets, each explained (part of ``Scene.warnings``)."""
    out = []
    src = scene.source or scene.name
    nyq = scene.max_beat_hz
    kind = "complex (I/Q) sampling rate" if scene.iq else "real (I-only) Nyquist rate fs/2"
    for i, t in enumerate(scene.targets):
        fb = scene.beat_hz(t)
        if fb < 0 or fb >= nyq:
            folded = fold_beat_hz(scene, fb)
            r_fold = folded * C_MPS / (2 * scene.slope_hz_per_s)
            f_range = scene.slope_hz_per_s * 2 * t.range_m / C_MPS
            r_range = fold_beat_hz(scene, f_range) * C_MPS / (2 * scene.slope_hz_per_s)
            out.append(f"{src}: targets[{i}].range_m: {t.range_m:g} m beats at {fb / 1e6:.2f} MHz "
                       f"({f_range / 1e6:.2f} MHz from range alone), beyond the {nyq / 1e6:g} MHz {kind} "
                       f"(max range {scene.max_range_m:.3g} m): it folds to {folded / 1e6:.2f} MHz and "
                       f"appears at about {r_fold:.2f} m ({r_range:.2f} m without Doppler)")
        tau = 2 * t.range_m / C_MPS
        if tau > scene.t_adc_start_s + 0.5 * scene.n_samples / scene.fs_hz:
            out.append(f"{src}: targets[{i}].range_m: round trip {tau * 1e6:.3g} us is more than half "
                       f"the sampling window: most samples hold no echo of this chirp")
        if abs(scene.range_rate_mps(t)) > scene.max_velocity_mps:
            out.append(velocity_warning(scene, i))
    return out


def aliased_targets(scene: Scene, max_speed_mps: float = 0.0) -> list[int]:
    """The targets whose range rate is beyond the unambiguous +-lambda / (4 t_chirp), where the Doppler FFT shows an
    alias, and beyond max_speed_mps, up to which an estimator following the range walk unaliases it
    (estimate/migration.py)."""
    return [i for i, t in enumerate(scene.targets)
            if abs(scene.range_rate_mps(t)) > max(scene.max_velocity_mps, max_speed_mps)]


def velocity_warning(scene: Scene, i: int) -> str:
    """Target i's range rate beyond the unambiguous velocity, and the alias the Doppler FFT shows."""
    rr, vmax = scene.range_rate_mps(scene.targets[i]), scene.max_velocity_mps
    folded_v = (rr + vmax) % (2 * vmax) - vmax
    return (f"{scene.source or scene.name}: targets[{i}].velocity_mps: range rate {rr:.3g} m/s ({rr * 3.6:.0f} km/h) "
            f"is beyond the unambiguous +-{vmax:.3g} m/s ({_repetition(scene)}): the Doppler FFT shows "
            f"{folded_v:.3g} m/s")


def _repetition(scene: Scene) -> str:
    if scene.n_slots == 1:
        return f"lambda / 4 t_chirp, t_chirp = {scene.t_chirp_s * 1e6:g} us"
    return (f"lambda / 4 T, T = {scene.n_slots} TDM slots x {scene.t_chirp_s * 1e6:g} us = "
            f"{scene.t_loop_s * 1e6:g} us between one transmitter's chirps")


def fold_beat_hz(scene: Scene, beat_hz: float) -> float:
    """Where a beat frequency lands after sampling: mod fs (complex), folded into [0, fs/2] (real)."""
    f = beat_hz % scene.fs_hz
    if not scene.iq and f > scene.fs_hz / 2:
        f = scene.fs_hz - f
    return f
