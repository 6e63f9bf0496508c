"""Alternating refinement of the targets of a cycle, the others cancelled (RELAX-style), on the compacted active
chirps x (C, A, N): the Doppler stage of every refining method and the beat stage of those without a joint step.

Beat: a method's `beat(y, f, k, read)` on the Doppler-compensated coherent sum over the active chirps,
y[n] = sum_m x[m, n] exp(-j 2 pi nu m), read from target k's first read sample on (Newton on its periodogram for
ml, MUSIC for the subspace methods).
Doppler: Newton on the non-uniform slow-time periodogram of the per-chirp DTFT z[m] = sum_{n >= r} x[m, n]
exp(-j 2 pi f n) at the beat, over the samples read for the target (from r on).

Each target's echo is a tone from its onset on (_onset.Onsets: echo), read from a few samples later (read). The
other targets, and for real samples the negative-frequency image of every target (x real = sum_k a_k e^{+j..} +
conj(a_k) e^{-j..}), each from its own onset, are removed in the reduced domain: their contributions to z and to y
are closed forms.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators import _onset
from carav_stream.estimate.estimators._common import Chirps, demod_slow, integrate_fast

# (y (C, N), f (C, K) the targets' beats, k, first sample read for target k (C,)) -> target k's refined beat (C,)
# [cycles/sample]
Beat = Callable[[np.ndarray, np.ndarray, int, np.ndarray], np.ndarray]


def _dirichlet(g, times, weights=None):
    """sum_t w_t exp(j 2 pi g t), g (C,), t = 0..len-1, weights None or (C, len)."""
    e = spectral.phasor(g, times.size, +1.0)
    return (e if weights is None else e * weights).sum(axis=1)


class _Tones:
    """The targets of a batch of cycles as they are refined: f [cycles/sample], nu [cycles/chirp] and the complex
    amplitude alpha, each (C, K), where their echoes are (echo) and where they are read (read), each (C, K, N) from
    their Onsets, and the closed forms of each target's share of z and y."""

    def __init__(self, x, chirps: Chirps, f, nu, iq: bool, onset: _onset.Onsets):
        self.n_cycles, self.n_samp = x.shape[0], x.shape[-1]
        self.echo = _onset.gates(onset.echo, self.n_samp)
        self.read = _onset.gates(onset.read, self.n_samp)
        self.n_read = (self.n_samp - onset.read).astype(float)
        self.n_chirps = chirps.n_chirps
        self.rho = chirps.rho
        self.rhof = chirps.rho.astype(float)
        self.m_times = np.arange(self.n_chirps, dtype=float)
        self.n_times = np.arange(self.n_samp, dtype=float)
        self.n_act = np.maximum(chirps.count, 1)
        self.iq = iq
        self.f, self.nu = f.copy(), nu.copy()
        self.alpha = np.zeros(f.shape, dtype=complex)

    def amplitude(self, z, k):
        """Complex amplitude of target k from its per-chirp DTFT z (C, M)."""
        mt = spectral.phasor(self.nu[:, k], self.n_chirps) * self.rho
        return (z * mt).sum(axis=1) / (self.n_read[:, k] * self.n_act)

    def interference_z(self, k):
        """(C, M) contribution of the others / images to z_k."""
        f, nu, alpha = self.f, self.nu, self.alpha
        out = np.zeros((self.n_cycles, self.n_chirps), dtype=complex)
        for j in range(f.shape[1]):
            both = self.echo[:, j] * self.read[:, k]     # the samples that hold target j's echo and are read for k
            if j != k:
                out += (alpha[:, j] * _dirichlet(f[:, j] - f[:, k], self.n_times, both))[:, None] * \
                    spectral.phasor(nu[:, j], self.n_chirps, +1.0) * self.rhof
            if not self.iq:
                out += (np.conj(alpha[:, j]) * _dirichlet(-f[:, j] - f[:, k], self.n_times, both))[:, None] * \
                    spectral.phasor(nu[:, j], self.n_chirps) * self.rhof
        return out

    def interference_y(self, k):
        """(C, N) contribution of the others / images to y_k."""
        f, nu, alpha = self.f, self.nu, self.alpha
        out = np.zeros((self.n_cycles, self.n_samp), dtype=complex)
        for j in range(f.shape[1]):
            if j != k:
                out += (alpha[:, j] * _dirichlet(nu[:, j] - nu[:, k], self.m_times, self.rhof))[:, None] * \
                    spectral.phasor(f[:, j], self.n_samp, +1.0) * self.echo[:, j]
            if not self.iq:
                out += (np.conj(alpha[:, j]) * _dirichlet(-nu[:, j] - nu[:, k], self.m_times, self.rhof))[:, None] * \
                    spectral.phasor(f[:, j], self.n_samp) * self.echo[:, j]
        return out

    def demod(self, x, chirps: Chirps, k):
        """Per-chirp DTFT (C, M) of the samples read for target k, at its beat."""
        return demod_slow(x, chirps, self.f[:, k], self.read[:, k])

    def refine_doppler(self, z, k, n_newton: int):
        """Newton steps on target k's Doppler from its per-chirp DTFT z, then its amplitude there."""
        self.nu[:, k] = spectral.newton_refine(z, self.nu[:, k], n_iter=n_newton, times=self.m_times)
        self.alpha[:, k] = self.amplitude(z, k)


def refine(x, chirps: Chirps, f, nu, beat: Beat, n_newton: int, iq: bool, onset: _onset.Onsets | None = None):
    """(f, nu, |alpha|), each (C, K), refined from (f, nu) (C, K): beat by `beat`, Doppler by Newton steps, the
    targets' echoes where `onset` says (None: every echo fills the window)."""
    onset = _onset.Onsets.none(f.shape) if onset is None else onset
    tones = _Tones(x, chirps, f, nu, iq, onset)
    if f.shape[1] == 1:
        _refine_one(x, chirps, tones, beat, n_newton, onset)
    else:
        _refine_several(x, chirps, tones, beat, n_newton, onset)
    return tones.f, tones.nu, np.abs(tones.alpha)


def _refine_one(x, chirps: Chirps, tones: _Tones, beat: Beat, n_newton: int, onset) -> None:
    """One target: integrate at the column Doppler (error ~0.01 bin: negligible loss), refine the beat, demodulate
    at it and refine the Doppler; the amplitude for the image of real samples comes from the integrated vector
    itself. Two passes over the data."""
    f = tones.f
    y = integrate_fast(x, chirps, tones.nu[:, 0])
    if not tones.iq:
        tones.alpha[:, 0] = (y * tones.read[:, 0] * spectral.phasor(f[:, 0], tones.n_samp)).sum(axis=1) / (
            tones.n_read[:, 0] * tones.n_act)
        y = y - tones.interference_y(0)
    f[:, 0] = beat(y, f, 0, onset.read[:, 0])
    z = tones.demod(x, chirps, 0)
    if not tones.iq:
        tones.alpha[:, 0] = tones.amplitude(z, 0)
        z = z - tones.interference_z(0)
    tones.refine_doppler(z, 0, n_newton)


def _refine_several(x, chirps: Chirps, tones: _Tones, beat: Beat, n_newton: int, onset) -> None:
    """Several targets: two rounds of alternating steps, Doppler then beat, target by target with the others
    cancelled, then the final Doppler at the final beats."""
    f, n_tgt = tones.f, tones.f.shape[1]
    z_at = [tones.demod(x, chirps, k) for k in range(n_tgt)]  # per-chirp DTFT at the current beat
    for k in range(n_tgt):
        tones.alpha[:, k] = tones.amplitude(z_at[k], k)
    for _ in range(2):
        for k in range(n_tgt):
            tones.refine_doppler(z_at[k] - tones.interference_z(k), k, n_newton)
            y = integrate_fast(x, chirps, tones.nu[:, k])
            f[:, k] = beat(y - tones.interference_y(k), f, k, onset.read[:, k])
            z_at[k] = tones.demod(x, chirps, k)
    for k in range(n_tgt):  # final Doppler at the final beats
        tones.refine_doppler(z_at[k] - tones.interference_z(k), k, n_newton)
