"""Waveform geometry the estimators need, and the FMCW conversions between beat/Doppler and range/velocity.

Sign convention (pinned; MATLAB ``dechirp`` convention, ``y = xref * conj(x)``):

    beat frequency   f_b = 2 * S * R / c  +  2 * v / lambda        [Hz]
    chirp phase      phi_m = phi_0 + 4 * pi * v * m * T_c / lambda  [rad], m = chirp index

with S the sweep slope [Hz/s], R the range [m], v the radial velocity (range rate) [m/s], positive when the
target recedes, lambda = c / f_c and T_c the chirp repetition interval. The Doppler *shift* f_d = -2 v / lambda
is positive for a closing target, so f_b = f_r - f_d as in MATLAB's FMCWExample; MATLAB reports the closing
speed -v as a positive number (1.0830 m/s for the table1 car, i.e. v = -1.0830 m/s here).

Range-Doppler coupling: a beat-only range 2 S R / c is off by (c / 2S)(2 v / lambda); ``range_from_beat``
removes it when given the velocity.

Echo onset: a chirp's echo reaches the receiver after its round trip tau = 2 R / c and is in the window from fast
time tau on; before it the receiver hears the previous chirp's echo, which beats at S (tau - T_c), outside the IF
band for every range the radar measures (carav_stream/radar/physics.py, beat_replica). A window that starts t_adc
into the ramp holds the echo from sample ceil((tau - t_adc) fs) on (``echo_onset``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.core.units import C_MPS


@dataclass(frozen=True)
class Geometry:
    """FMCW waveform as seen by the estimators.

    fs_hz           ADC sample rate [Hz]
    slope_hz_per_s  sweep slope S [Hz/s]
    fc_hz           carrier (operating) frequency [Hz]
    t_chirp_s       chirp repetition interval T_c [s] (slow-time sample spacing)
    n_samples       fast-time samples per chirp
    iq              True: complex (I/Q) samples; False: real (I-only) samples
    t_adc_start_s   fast time of the first sample after the ramp's start (TI's adcStartTime) [s]

    The chirp-to-chirp phase progression depends on the fast time it is read at. At t' the echo's phase 2 pi (fc tau +
    S t' tau - S tau^2 / 2) advances by 2 pi alpha T_c (fc + S (t' - tau)), alpha = 2 v / c (the beat walks with the
    range), so read at sample n of a window that starts t_adc into the ramp the Doppler is scaled by
    1 + S (t_adc + n / fs - tau) / fc (``doppler_scale_at``): 1.1e-3 on AWR1642 at its first sample (a 7 us start),
    3.2e-3 at its window's centre. The velocity conversions below take it out, at the first sample and tau = 0 unless
    told: a sum over the samples n0..N-1 (an FFT, a DTFT at the beat) reads the progression at their centre
    (n0 + N - 1) / 2.
    """

    fs_hz: float
    slope_hz_per_s: float
    fc_hz: float
    t_chirp_s: float
    n_samples: int
    iq: bool = True
    t_adc_start_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("fs_hz", "slope_hz_per_s", "fc_hz", "t_chirp_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"Geometry.{name}: must be a finite number > 0, got {value!r}")
        if int(self.n_samples) != self.n_samples or self.n_samples < 4:
            raise ValueError(f"Geometry.n_samples: must be an integer >= 4, got {self.n_samples!r}")
        if not (np.isfinite(self.t_adc_start_s) and self.t_adc_start_s >= 0):
            raise ValueError(f"Geometry.t_adc_start_s: must be a finite number >= 0, got {self.t_adc_start_s!r}")
        object.__setattr__(self, "n_samples", int(self.n_samples))
        object.__setattr__(self, "iq", bool(self.iq))

    @classmethod
    def from_scene(cls, scene: object) -> Geometry:
        """Read fs_hz, slope_hz_per_s, fc_hz, t_chirp_s, n_samples, iq and, if it has one, t_adc_start_s from any
        object (duck typing)."""
        names = ("fs_hz", "slope_hz_per_s", "fc_hz", "t_chirp_s", "n_samples", "iq")
        missing = [n for n in names if not hasattr(scene, n)]
        if missing:
            raise TypeError(f"Geometry.from_scene: {type(scene).__name__} lacks attribute(s) {missing}; "
                            f"expected all of {list(names)}")
        return cls(*(getattr(scene, n) for n in names), t_adc_start_s=float(getattr(scene, "t_adc_start_s", 0.0)))

    @property
    def wavelength_m(self) -> float:
        """Carrier wavelength lambda = c / f_c [m]."""
        return C_MPS / self.fc_hz

    @property
    def range_per_hz_m(self) -> float:
        """Range per hertz of beat frequency, c / (2 S) [m/Hz]."""
        return C_MPS / (2.0 * self.slope_hz_per_s)

    @property
    def range_resolution_m(self) -> float:
        """Range resolution of one chirp's sampled window, c / (2 S N / fs) [m]."""
        return self.range_per_hz_m * self.fs_hz / self.n_samples

    @property
    def max_range_m(self) -> float:
        """Largest unambiguous range: beat < fs (complex) or fs/2 (real), Doppler ignored [m]."""
        return self.range_per_hz_m * self.fs_hz * (1.0 if self.iq else 0.5)

    @property
    def max_velocity_mps(self) -> float:
        """Unambiguous radial velocity: |v| < lambda / (4 T_c) [m/s] (the textbook figure; the phase progression at
        the first sample folds at this over the Doppler scale, which the velocity conversions use)."""
        return self.wavelength_m / (4.0 * self.t_chirp_s)

    @property
    def doppler_scale(self) -> float:
        """1 + S t_adc / fc: the chirp-to-chirp phase progression at the first sample over 2 v T_c / lambda."""
        return 1.0 + self.slope_hz_per_s * self.t_adc_start_s / self.fc_hz

    def doppler_scale_at(self, sample=0.0, delay_s=0.0):
        """1 + S (t_adc + n / fs - tau) / fc: the chirp-to-chirp phase progression at sample n of the window of an
        echo delayed by tau (floats, broadcast) over 2 v T_c / lambda."""
        late = np.asarray(sample, dtype=float) / self.fs_hz - np.asarray(delay_s, dtype=float)
        return self.doppler_scale + self.slope_hz_per_s * late / self.fc_hz

    def echo_onset(self, range_m):
        """First sample of the window [0, n_samples] at or after the round trip 2 R / c of a target at range_m [m]
        (0 when the echo is there before the window starts), int64 of range_m's shape."""
        late = (2.0 * np.asarray(range_m, dtype=float) / C_MPS - self.t_adc_start_s) * self.fs_hz
        return np.clip(np.ceil(np.round(late, 6)), 0, self.n_samples).astype(np.int64)  # round: 27.0000001 is 27

    def range_seen(self, range_m, velocity_mps, rho):
        """Range [m] (n_cycles, K) that the beat of an echo measures, for targets at range_m (K,) or (n_cycles, K) at
        the cycle's start moving at velocity_mps (same shape), rho bool (n_cycles, n_chirps) the active chirps.

        Chirp m's beat is S tau(t) at t = m T_c + 2 t', t' the fast time of its samples' middle (the delay grows
        within the chirp too: d/dt' of S t' tau(m T_c + t') is S tau + S t' alpha), so a beat over the active chirps
        and the samples from the echo's onset on measures the range at the mean active chirp start plus twice the
        fast time of those samples' middle."""
        rho = np.asarray(rho, dtype=bool)
        r = np.asarray(range_m, dtype=float)
        r = r if r.ndim == 2 else np.broadcast_to(r, (rho.shape[0], r.size))
        m_mean = (rho * np.arange(rho.shape[1])).sum(axis=1) / np.maximum(rho.sum(axis=1), 1)
        middle = self.t_adc_start_s + (self.echo_onset(r) + self.n_samples - 1) / (2.0 * self.fs_hz)
        return r + np.asarray(velocity_mps, dtype=float) * (m_mean[:, None] * self.t_chirp_s + 2.0 * middle)

    def beat_from_range(self, range_m, velocity_mps=0.0):
        """Beat frequency [Hz] of a target at range_m [m] with radial velocity velocity_mps [m/s]."""
        return (np.asarray(range_m, dtype=float) / self.range_per_hz_m
                + 2.0 * np.asarray(velocity_mps, dtype=float) / self.wavelength_m)

    def range_from_beat(self, beat_hz, velocity_mps=0.0):
        """Range [m] from beat frequency [Hz], removing the Doppler term 2 v / lambda (coupling)."""
        return self.range_per_hz_m * (np.asarray(beat_hz, dtype=float)
                                      - 2.0 * np.asarray(velocity_mps, dtype=float) / self.wavelength_m)

    def velocity_from_slow_freq(self, nu_cycles_per_chirp, sample=None, delay_s=0.0):
        """Radial velocity [m/s] from the chirp-to-chirp phase progression nu [cycles/chirp] of an echo delayed by
        delay_s read at `sample` of the window (None: the first sample, no delay; doppler_scale_at)."""
        scale = self.doppler_scale if sample is None else self.doppler_scale_at(sample, delay_s)
        return np.asarray(nu_cycles_per_chirp, dtype=float) * self.wavelength_m / (2.0 * self.t_chirp_s * scale)

    def slow_freq_from_velocity(self, velocity_mps, sample=None, delay_s=0.0):
        """Chirp-to-chirp phase progression nu = 2 v T_c / lambda (1 + S (t_adc + n / fs - tau) / fc) [cycles/chirp]
        (not wrapped) at sample n = `sample` of the window, of an echo delayed by tau = delay_s (None: the first
        sample, no delay)."""
        scale = self.doppler_scale if sample is None else self.doppler_scale_at(sample, delay_s)
        return np.asarray(velocity_mps, dtype=float) * 2.0 * self.t_chirp_s * scale / self.wavelength_m
