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

    The chirp-to-chirp phase progression is read at the first sample. There the echo's phase 2 pi (fc tau +
    S t' tau) advances by 2 pi alpha T_c (fc + S t'), alpha = 2 v / c, so a window that starts t_adc into the
    ramp scales the Doppler by 1 + S t_adc / fc (1.1e-3 on AWR1642 with a 7 us start): the velocity conversions
    below take it out.
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

    def beat_from_range(self, range_m, velocity_mps=0.0):
        """Beat frequency [Hz] of a target at range_m [m] with radial velocity velocity_mps [m/s]."""
        return (np.asarray(range_m, dtype=float) / self.range_per_hz_m
                + 2.0 * np.asarray(velocity_mps, dtype=float) / self.wavelength_m)

    def range_from_beat(self, beat_hz, velocity_mps=0.0):
        """Range [m] from beat frequency [Hz], removing the Doppler term 2 v / lambda (coupling)."""
        return self.range_per_hz_m * (np.asarray(beat_hz, dtype=float)
                                      - 2.0 * np.asarray(velocity_mps, dtype=float) / self.wavelength_m)

    def velocity_from_slow_freq(self, nu_cycles_per_chirp):
        """Radial velocity [m/s] from the chirp-to-chirp phase progression nu [cycles/chirp]."""
        return (np.asarray(nu_cycles_per_chirp, dtype=float) * self.wavelength_m
                / (2.0 * self.t_chirp_s * self.doppler_scale))

    def slow_freq_from_velocity(self, velocity_mps):
        """Chirp-to-chirp phase progression nu = 2 v T_c / lambda (1 + S t_adc / fc) [cycles/chirp] (not wrapped)."""
        return np.asarray(velocity_mps, dtype=float) * 2.0 * self.t_chirp_s * self.doppler_scale / self.wavelength_m
