"""Cramer-Rao lower bounds for a single tone in white Gaussian noise, in range and velocity units.

Complex tone a*exp(j(2 pi f n + phi)) in circular complex noise of variance sigma^2, samples at times t_n
(in sample units), unknown a, phi, f; SNR = a^2 / sigma^2:

    var(f_hat) >= 1 / (2 SNR (2 pi)^2 sum_n (t_n - mean t)^2)        [cycles/sample]^2

which for t_n = 0..N-1 is the textbook 6 / ((2 pi)^2 SNR N (N^2 - 1)) (Rife & Boorstyn 1974, Kay 1993).
A real tone a*cos(.) in real noise of variance sigma^2 has SNR = a^2 / (2 sigma^2) and twice that bound.

For an FMCW cycle (fast time n, active chirps m in the set A, |A| = M) the 2-D model decouples when both time
origins are centred: the beat frequency sees N samples at SNR * M, the slow-time frequency sees the |A|
chirp times at SNR * N. Range from the beat after coupling correction, R = c/(2S) (f_b - 2v/lambda),
inherits both variances.

An echo that arrives after the window starts (its round trip beyond the ADC start: Geometry.echo_onset) is there
for N - n0 samples only, and the samples before its onset tell nothing of it: with the target's range given, the
bound counts the samples that hold the echo.
"""
from __future__ import annotations

import numpy as np

from carav_stream.estimate.geometry import Geometry


def tone_frequency_crlb(snr, n_samples=None, *, times=None, iq: bool = True):
    """CRLB of the frequency of one tone [cycles/sample^2], as a float array broadcast over snr.

    snr        linear SNR per sample (signal power / noise power), array-like
    n_samples  N for uniform sampling t = 0..N-1 (exclusive with times)
    times      sample times in sample units, shape (..., N); the bound uses sum (t - mean t)^2 over the last axis
    iq         False for a real tone in real noise (bound doubles)
    """
    snr = np.asarray(snr, dtype=float)
    if (n_samples is None) == (times is None):
        raise ValueError("tone_frequency_crlb: give exactly one of n_samples or times")
    if times is not None:
        t = np.asarray(times, dtype=float)
        spread = np.sum((t - t.mean(axis=-1, keepdims=True)) ** 2, axis=-1)
    else:
        n = np.asarray(n_samples, dtype=float)
        spread = n * (n * n - 1.0) / 12.0
    with np.errstate(divide="ignore"):
        bound = 1.0 / (2.0 * snr * (2.0 * np.pi) ** 2 * spread)
    return bound * (1.0 if iq else 2.0)


def slow_time_spread(rho) -> np.ndarray:
    """sum over active chirps of (m - mean m)^2 [chirps^2], shape rho.shape[:-1]; rho bool (..., n_chirps)."""
    rho = np.asarray(rho, dtype=bool)
    m = np.arange(rho.shape[-1], dtype=float)
    n_act = rho.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = (rho * m).sum(axis=-1) / n_act
    return (rho * (m - mean[..., None]) ** 2).sum(axis=-1)


def fmcw_crlb(geometry: Geometry, snr_sample_db, rho, *, couple: bool = True,
              range_m=None) -> dict[str, np.ndarray]:
    """Range and velocity CRLB standard deviations for one target in one FMCW cycle.

    geometry       waveform
    snr_sample_db  per-sample SNR [dB] before any integration (signal power / noise power per ADC sample, while
                   the echo is there)
    rho            bool (..., n_chirps): active chirps of the cycle(s)
    couple         add the velocity variance carried into range by the coupling correction
    range_m        the target's range [m], broadcast with the others: the bound then counts the samples from its
                   echo's onset on (Geometry.echo_onset); None: every sample holds the echo (a tone over the window)
    Returns dict of float arrays broadcast over snr_sample_db and rho.shape[:-1]: beat_hz, range_m (std),
    slow_cycles (std, cycles/chirp), velocity_mps (std) and snr_integrated_db (SNR after coherent integration
    over the active chirps, the SNR the fast-time estimators work at).
    """
    rho = np.asarray(rho, dtype=bool)
    snr = 10.0 ** (np.asarray(snr_sample_db, dtype=float) / 10.0)
    n_act = rho.sum(axis=-1).astype(float)
    n = geometry.n_samples if range_m is None else geometry.n_samples - geometry.echo_onset(range_m)
    var_f = tone_frequency_crlb(snr * n_act, n, iq=geometry.iq)
    spread = slow_time_spread(rho)
    with np.errstate(divide="ignore"):
        var_nu = (1.0 / (2.0 * snr * n * (2.0 * np.pi) ** 2 * spread)) * (1.0 if geometry.iq else 2.0)
    var_beat = var_f * geometry.fs_hz ** 2
    var_v = var_nu * float(geometry.velocity_from_slow_freq(1.0)) ** 2
    var_r = geometry.range_per_hz_m ** 2 * (var_beat + (var_v * (2.0 / geometry.wavelength_m) ** 2 if couple else 0.0))
    with np.errstate(divide="ignore"):
        snr_int_db = 10.0 * np.log10(snr * n_act)
    return {"beat_hz": np.sqrt(var_beat), "range_m": np.sqrt(var_r), "slow_cycles": np.sqrt(var_nu),
            "velocity_mps": np.sqrt(var_v), "snr_integrated_db": snr_int_db}
