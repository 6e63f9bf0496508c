"""The beat stage of the subspace methods (music, root_music): MUSIC on the Doppler-compensated coherent sum y over
the active chirps, read from the target's echo onset on (_onset); the Doppler stage is ml's (_relax). Model order K
for I/Q samples, 2K for real (I-only) ones (each tone and its image).

Covariance: forward-backward smoothed, of the subvectors h_s = y[s : s + L] that lie wholly after the onset n0,

    R = (R_f + J conj(R_f) J) / 2,    R_f = 1/S sum_{s = n0}^{N - L} h_s h_s^H,    S the number of those subvectors

(J the exchange matrix), and the signal subspace E_s its r = K or 2K dominant eigenvectors.

music: the subvector length is a quarter of the window by default, where a single tone's MUSIC estimate lies near
the bound (at 32 samples of table1's 1080 it lies 2.5 to 3 times above it, whatever the SNR). Its signal subspace
comes from subspace iteration, E <- orth(R E) N_ITER times from the steering vectors a(f) (a(-f) too for real
samples) of the targets' current beats, R's products by FFT correlations of y (R_f v = 1/S sum_s h_s (h_s^H v): two
correlations of y, one with v, one with the S products), so the L x L covariance is never formed: the start lies a
fraction of a bin from the answer and the signal eigenvalues L SNR above the noise's, so two iterations leave the
subspace where an eigendecomposition puts it, far below the noise's error. The beat is the maximum of the
signal-subspace form of the pseudo-spectrum, 1 / ||E_n^H a(f)||^2 = 1 / (L - ||E_s^H a(f)||^2), by Newton steps on
||E_s^H a(f)||^2 = sum_k |DTFT(e_k)(f)|^2 from the current beat.

root_music: the covariance formed (subvector length min(N / 4, 32) by default: rooting a polynomial of degree 2L - 2
costs L^3), its eigenvectors, and the root of the root-MUSIC polynomial nearest the current beat among the r
nearest the unit circle (spectral.root_music_roots).
"""
from __future__ import annotations

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators import _onset, _relax
from carav_stream.estimate.estimators._common import Chirps

N_ITER = 2       # subspace iterations from the steering vectors of the current beats
N_PEAK = 3       # Newton steps on ||E_s^H a(f)||^2


def default_length(n_samp: int, root: bool) -> int:
    """The subvector length L without music_length: N // 4, or min(N // 4, 32) for root_music."""
    return int(min(n_samp // 4, 32)) if root else n_samp // 4


def _windows(onset, n_samp: int, length: int):
    """float64 (C, S): 1 for the subvectors y[s : s + L] that start at or after the onset (C,), and their count (C,)."""
    w = (np.arange(n_samp - length + 1) >= onset[:, None]).astype(float)
    return w, np.maximum(w.sum(axis=1), 1.0)


def fb_apply(y_fft, windows, n_windows, v, length: int):
    """R v (C, L, r) for the forward-backward smoothed covariance R of the subvectors `windows` (C, S) of y, from
    y's FFT y_fft (C, nfft), nfft >= N: R_f v = 1/S sum_s h_s conj(c_s), c_s = sum_l y[s + l] conj(v[l]), both sums
    circular correlations without wrap at that length; R_b v = J conj(R_f conj(J v))."""
    nfft = y_fft.shape[-1]
    r = v.shape[-1]
    both = np.concatenate([v, np.conj(v[:, ::-1])], axis=-1)                      # (C, L, 2r): v, conj(J v)
    c = scipy.fft.ifft(y_fft[:, :, None] * np.conj(scipy.fft.fft(both, n=nfft, axis=1)), axis=1)
    c = c[:, :windows.shape[1]] * windows[:, :, None]                           # (C, S, 2r)
    out = scipy.fft.ifft(y_fft[:, :, None] * np.conj(scipy.fft.fft(c, n=nfft, axis=1)), axis=1)[:, :length]
    out /= n_windows[:, None, None]
    return 0.5 * (out[..., :r] + np.conj(out[:, ::-1, r:]))


def _orth(v):
    """Orthonormal basis (C, L, r) of the columns of v (C, L, r)."""
    if v.shape[-1] == 1:
        return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    return np.linalg.qr(v)[0]


def signal_subspace(y, starts, onset, length: int):
    """Orthonormal (C, L, r): the r-dimensional dominant subspace of the covariance of the subvectors after the
    onset (C,), by N_ITER subspace iterations from the steering vectors a(starts), starts (C, r) [cycles/sample]."""
    n_samp = y.shape[-1]
    y_fft = scipy.fft.fft(y, n=scipy.fft.next_fast_len(n_samp), axis=-1)
    windows, n_windows = _windows(onset, n_samp, length)
    v = np.exp(2j * np.pi * np.arange(length)[None, :, None] * starts[:, None, :])
    for _ in range(N_ITER):
        v = _orth(fb_apply(y_fft, windows, n_windows, _orth(v), length))
    return v


def subspace_peak(sig, f0, n_iter: int = N_PEAK):
    """The beat [cycles/sample] (C,) nearest f0 (C,) that maximises ||E_s^H a(f)||^2 = sum_k |sum_l conj(e_k[l])
    exp(j 2 pi f l)|^2 for the orthonormal signal eigenvectors sig (C, L, r): safeguarded Newton steps (clipped to
    half a bin of L; the result never below the start's value)."""
    e = np.swapaxes(sig, 1, 2)                                                   # (C, r, L)
    length, r = e.shape[-1], e.shape[1]
    f, q0 = np.asarray(f0, dtype=float).copy(), None
    for _ in range(n_iter):
        y0, y1, y2 = spectral.dtft_derivatives(e, np.repeat(f[:, None], r, axis=1))
        if q0 is None:
            q0 = (np.abs(y0) ** 2).sum(axis=1)
        d1 = (2.0 * np.real(np.conj(y0) * y1)).sum(axis=1)
        d2 = (2.0 * (np.abs(y1) ** 2 + np.real(np.conj(y0) * y2))).sum(axis=1)
        step = np.where(d2 < 0, -d1 / np.where(d2 < 0, d2, -1.0), np.sign(d1) * 0.125 / length)
        f = f + np.clip(step, -0.5 / length, 0.5 / length)
    (y0,) = spectral.dtft_derivatives(e, np.repeat(f[:, None], r, axis=1), order=0)
    return np.where((np.abs(y0) ** 2).sum(axis=1) < q0, f0, f)


def _covariance(y, onset, length: int):
    """The forward-backward smoothed covariance (C, L, L) of the subvectors after the onset (C,)."""
    h = np.lib.stride_tricks.sliding_window_view(y, length, axis=-1)           # (C, S, L)
    windows, n_windows = _windows(onset, y.shape[-1], length)
    r = np.matmul(np.swapaxes(h * windows[:, :, None], 1, 2), h.conj()) / n_windows[:, None, None]
    return 0.5 * (r + np.flip(r, axis=(-2, -1)).conj())


def music_beat(y, f, k: int, onset, *, n_per: int, length: int, root: bool):
    """Target k's beat [cycles/sample] (C,) by MUSIC on y (C, N) from sample `onset` (C,) on; f (C, K) the targets'
    current beats, n_per 1 (I/Q) or 2 (real: each tone and its image) signal dimensions per target."""
    n_model = n_per * f.shape[1]
    f_k = f[:, k]
    if root:
        _, sig = spectral.subspaces(_covariance(y, onset, length), n_model)
        cand, _ = spectral.root_music_roots(sig, n_model)
        d = (cand - f_k[:, None] + 0.5) % 1.0 - 0.5
        pick = np.argmin(np.abs(d), axis=1)
        return f_k + np.take_along_axis(d, pick[:, None], axis=1)[:, 0]
    starts = np.concatenate([f, -f], axis=1) if n_per == 2 else f                # target k's own first
    starts = np.concatenate([starts[:, k:k + 1], np.delete(starts, k, axis=1)], axis=1)
    return subspace_peak(signal_subspace(y, starts, onset, length), f_k)


def refine_music(x, chirps: Chirps, f, nu, *, root: bool, n_newton: int, music_length: int | None, iq: bool,
                 onset: _onset.Onsets | None = None):
    """(f, nu, amp), each (C, K), refined from (f, nu): beat by MUSIC (root-MUSIC with `root`) with subvector length
    music_length (default_length without it), Doppler by Newton steps, the other targets and the images cancelled,
    the targets' echoes where `onset` says (None: every echo fills the window)."""
    n_samp = x.shape[-1]
    length = music_length or default_length(n_samp, root)

    def beat(y, f_now, k, read):
        return music_beat(y, f_now, k, read, n_per=1 if iq else 2, length=length, root=root)

    return _relax.refine(x, chirps, f, nu, beat, n_newton, iq, onset)
