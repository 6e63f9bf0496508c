"""Closed-form FMCW beat signals for tests and benchmarks (no dependency on the radar simulator).

    x[c, m, n] = rho[c, m] * sum_k a_k exp(j (2 pi f_k n / fs + 2 pi nu_k m + phi_ck)) + w[c, m, n]
    f_k  = 2 S R_k / c + 2 v_k / lambda      (geometry.beat_from_range)
    nu_k = 2 v_k T_c / lambda                 (cycles/chirp)

Real (I-only) geometry: the real part, a_k cos(.), with real noise. The per-sample SNR refers to the first
target: complex a_0^2 / sigma^2, real a_0^2 / (2 sigma^2), where sigma^2 is the noise variance per sample.

Two parts of an echo that the plain tones leave out, each an option:
    migrate  the range moves by v m T_c from chirp to chirp, so the beat walks and the chirp-to-chirp phase
             progression is read at each sample where the radar reads it (nu_k at the first sample, of an echo
             delayed by tau = 2 R / c: Geometry.slow_freq_from_velocity with that delay); an estimator then
             measures the range at the mean time of the active chirps (``centroid_ranges``)
    gate     each tone is there from its echo's round trip on (Geometry.echo_onset), zero before it
"""
from __future__ import annotations

import numpy as np

from carav_stream.core.units import C_MPS
from carav_stream.estimate.geometry import Geometry


def synth_beat(geometry: Geometry, rho, ranges_m, velocities_mps, *, amplitudes=1.0, snr_sample_db=None,
               rng: np.random.Generator, migrate: bool = False, gate: bool = False) -> np.ndarray:
    """Frames (n_cycles, n_chirps, n_samples), complex64 (iq) or float32.

    rho             bool (n_cycles, n_chirps): chirps that carry echoes
    ranges_m        (K,) or (n_cycles, K) target ranges at chirp 0 [m]
    velocities_mps  same shape, radial velocities [m/s], positive receding
    amplitudes      same shape or scalar, tone amplitudes
    snr_sample_db   per-sample SNR of target 0 [dB]; None for noise-free frames
    rng             numpy Generator for the random phases and the noise
    migrate, gate   the range walk and the echo's onset (module docstring)
    """
    rho = np.asarray(rho, dtype=bool)
    if rho.ndim != 2:
        raise ValueError(f"synth_beat: rho must be (n_cycles, n_chirps), got shape {rho.shape}")
    n_cycles, n_chirps = rho.shape
    r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
    r = np.broadcast_to(r if r.ndim == 2 else r[None, :], (n_cycles, r.shape[-1]))
    v = np.broadcast_to(np.asarray(velocities_mps, dtype=float), r.shape)
    a = np.broadcast_to(np.asarray(amplitudes, dtype=float), r.shape)
    n = np.arange(geometry.n_samples, dtype=float)
    m = np.arange(n_chirps, dtype=float)
    phi0 = rng.uniform(0.0, 2.0 * np.pi, size=r.shape)
    # migrating: the progression at the first sample of an echo delayed by 2 R / c, as the radar reads it
    nu = (geometry.slow_freq_from_velocity(v, sample=0.0, delay_s=2.0 * r / C_MPS) if migrate
          else geometry.slow_freq_from_velocity(v))
    x = np.zeros((n_cycles, n_chirps, geometry.n_samples), dtype=complex)
    for k in range(r.shape[1]):
        if migrate:
            r_cm = r[:, k, None] + v[:, k, None] * m[None, :] * geometry.t_chirp_s
            f_cm = geometry.beat_from_range(r_cm, v[:, k, None]) / geometry.fs_hz  # (C, M) cycles/sample
        else:
            f_cm = np.broadcast_to((geometry.beat_from_range(r[:, k], v[:, k]) / geometry.fs_hz)[:, None],
                                   (n_cycles, n_chirps))
        slow = 2.0 * np.pi * nu[:, k, None] * m[None, :] + phi0[:, k, None]  # (C, M)
        phase = 2.0 * np.pi * f_cm[..., None] * n + slow[..., None]
        tone = a[:, k, None, None] * np.exp(1j * phase)
        if gate:
            tone *= (n >= geometry.echo_onset(r[:, k])[:, None])[:, None, :]
        x += tone
    x *= rho[..., None]
    if not geometry.iq:
        x = x.real
    if snr_sample_db is not None:
        a0 = np.abs(a[:, 0])[:, None, None]
        snr = 10.0 ** (snr_sample_db / 10.0)
        if geometry.iq:
            sigma = a0 / np.sqrt(snr)
            noise = (rng.standard_normal(x.shape) + 1j * rng.standard_normal(x.shape)) * (sigma / np.sqrt(2.0))
        else:
            sigma = a0 / np.sqrt(2.0 * snr)
            noise = rng.standard_normal(x.shape) * sigma
        x = x + noise
    return x.astype(np.complex64 if geometry.iq else np.float32)


def centroid_ranges(geometry: Geometry, rho, ranges_m, velocities_mps) -> np.ndarray:
    """Range [m] (n_cycles, K) of each migrating tone (synth_beat with migrate) at the mean time of its cycle's
    active chirps: R + v T_c mean(m active), what an estimator of one beat per cycle measures."""
    rho = np.asarray(rho, dtype=bool)
    m_mean = (rho * np.arange(rho.shape[1])).sum(axis=1) / np.maximum(rho.sum(axis=1), 1)
    return (np.asarray(ranges_m, dtype=float) + np.asarray(velocities_mps, dtype=float)
            * geometry.t_chirp_s * m_mean[:, None])


def random_rho(rng: np.random.Generator, n_cycles: int, n_chirps: int, p_active: float = 0.5,
               min_active: int = 2) -> np.ndarray:
    """Bernoulli(p_active) activation pattern (n_cycles, n_chirps) bool with at least min_active per cycle."""
    rho = rng.random((n_cycles, n_chirps)) < p_active
    short = rho.sum(axis=1) < min_active
    while np.any(short):
        rho[short] = rng.random((int(short.sum()), n_chirps)) < p_active
        short = rho.sum(axis=1) < min_active
    return rho
