"""The range-Doppler map every method starts from: model order, the strongest cell, values at cells, and the
interpolated sub-bin start around a cell.

Range-Doppler map |FFT_slow(FFT_fast(x))|^2 of the compacted active chirps (fast-time FFT length nr, slow-time
length md), transformed in slow time only at the range bins that can hold its maximum; the number of targets is
given, or estimated by MDL/AIC on a Toeplitz covariance built from the non-coherently integrated power spectrum of
the active chirps.
"""
from __future__ import annotations

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.estimators._common import Chirps, turns


def estimate_order(x, chirps: Chirps, criterion: str, max_targets: int, iq: bool):
    """Model order per cycle from MDL/AIC on the Toeplitz covariance of the active chirps' summed power."""
    n = x.shape[-1]
    length = int(min(max(4 * max_targets + 4, 16), n // 2))
    nfft = scipy.fft.next_fast_len(2 * n)
    spec = scipy.fft.fft(x.astype(np.complex128), n=nfft, axis=-1)
    power = (np.abs(spec) ** 2).sum(axis=1)
    cov = spectral.toeplitz_covariance_from_power(power, length, n)
    eig = np.linalg.eigvalsh(cov)
    snaps = np.maximum(chirps.count * (n // length), 1)
    per = 1 if iq else 2
    order = spectral.information_criterion_order(eig, snaps, criterion=criterion, max_order=per * max_targets)
    return np.minimum((order + per - 1) // per, max_targets)


def search(spec, chirps: Chirps, md: int, iq: bool):
    """Cell (l0, k0), each (C, 1), of the largest |RD| of the range-Doppler map RD = FFT_md(spec) along slow
    time (spec (C, A, nb) the compacted range spectra). Real samples: DC and Nyquist are not searched.

    Only the range bins that can hold the maximum are transformed: the largest |RD[l, k]|^2 over l lies between
    the mean E_k = sum_m |spec[m, k]|^2 (Parseval) and count * E_k (Cauchy-Schwarz over the active chirps), so a
    bin with count * E_k < max_k E_k cannot win (0.1 % margin for float32 rounding). With a target above the
    noise that leaves a few bins around it; otherwise the whole map is computed."""
    n_cycles, _, nb = spec.shape
    energy = np.abs(spec)
    energy = np.square(energy, out=energy).sum(axis=1)  # (C, nb)
    if not iq:
        energy[:, [0, -1]] = -1.0
    top = energy.max(axis=1, keepdims=True)
    keep = (energy * (1.001 * chirps.count[:, None]) >= top) & (top > 0)
    keep[np.arange(n_cycles), np.argmax(energy, axis=1)] = True  # empty cycles: one bin, any
    n_keep = int(keep.sum(axis=1).max())
    if 2 * n_keep > nb:
        cols = np.broadcast_to(np.arange(nb), (n_cycles, nb))
    else:
        cols = np.argsort(~keep, axis=1, kind="stable")[:, :n_keep]
        spec = np.take_along_axis(spec, cols[:, None, :], axis=2)
        keep = np.take_along_axis(keep, cols, axis=1)
    mag = np.abs(scipy.fft.fft(chirps.scatter(spec), n=md, axis=1, overwrite_x=True))  # (C, md, P)
    if not keep.all():
        mag *= keep[:, None, :]
    l0, p0 = np.divmod(np.argmax(mag.reshape(n_cycles, -1), axis=1)[:, None], mag.shape[2])
    return l0, np.take_along_axis(cols, p0, axis=1)


def cells(spec, chirps: Chirps, l, k, md: int):
    """Range-Doppler values RD[l, k] = sum_m spec[m, k] exp(-j 2 pi l m / md) at the cells (l, k), each (C, J)
    (l any integer, k in range), complex128 (C, J)."""
    col = np.take_along_axis(spec, k[:, None, :], axis=2).astype(complex)  # (C, A, J)
    phase_turns = (chirps.index[:, :, None] * l[:, None, :]) % md / md  # exact integer phase
    return (col * np.exp(-2j * np.pi * phase_turns) * chirps.mask[:, :, None]).sum(axis=1)


def start(spec, chirps: Chirps, k0, l0, n_samp: int, pad: int):
    """Sub-bin start (f [cycles/sample], nu [cycles/chirp], |RD| there), each (C, K), of the targets at the cells
    (l0, k0) (C, K) of the compacted range spectra spec (C, A, nb).

    nu: the parabolic vertex of |RD| along range bin k0 on a pad-times zero-padded Doppler FFT, at its global
    maximum for one target (robust to the high sidelobes of the sparse active set when the coarse grid scallops),
    within one coarse bin of l0 for several. f: Candan's three-bin interpolation across bins k0 - 1, k0, k0 + 1
    (clipped to the spectrum) at that padded Doppler cell (exact integer phases; n_samp the unpadded length).
    pad (a method's start_pad): 8 where nu is the answer (fft_interp: a coarser grid's parabolic vertex is biased
    at high SNR), 2 where it is a start (ml: RMSE / CRLB within 1.05 from 0 to 30 dB on both presets, as with 4 or
    8; with 1, the coarse grid, one Newton step no longer reaches the bound: 16 to 166 x the CRLB in velocity on
    table1 from 10 to 30 dB, carav bench estimators --estimators fft_peak,ml at 500 cycles)."""
    n_cycles, _, nb = spec.shape
    n_tgt = k0.shape[1]
    n_pad = chirps.n_chirps * pad
    c = np.arange(n_cycles)[:, None, None]
    t = np.arange(n_tgt)[None, :, None]
    col = np.zeros((n_cycles, n_tgt, chirps.n_chirps), dtype=spec.dtype)
    col[c, t, chirps.index[:, None, :]] = spec[c[..., 0], :, k0]  # (C, K, M): silent chirps zero
    pw = np.abs(scipy.fft.fft(col, n=n_pad, axis=-1, overwrite_x=True))  # (C, K, n_pad)
    if n_tgt == 1:
        j = np.argmax(pw, axis=-1)  # (C, K)
    else:
        win = (np.arange(-pad, pad + 1) + (l0 * pad)[..., None]) % n_pad
        j = np.take_along_axis(win, np.argmax(np.take_along_axis(pw, win, axis=-1), axis=-1)[..., None],
                               axis=-1)[..., 0]
    p = pw[c, t, (j[..., None] + np.arange(-1, 2)) % n_pad].astype(float)  # (C, K, 3)
    nu = (j + spectral.parabolic_delta(p[..., 0], p[..., 1], p[..., 2])) / n_pad
    # the three range bins at that Doppler cell: exact integer phases over the active chirps (padding rows are 0)
    rows = spec[c, :, np.clip(k0[..., None] + np.arange(-1, 2), 0, nb - 1)]  # (C, K, 3, A)
    e = turns(n_pad, spec.dtype)[(chirps.index[:, None, :] * j[..., None]) % n_pad]  # (C, K, A)
    v = np.matmul(rows, e[..., None])[..., 0].astype(complex)  # (C, K, 3): a product per cycle
    f = (k0 + spectral.candan_delta(v[..., 0], v[..., 1], v[..., 2], n_samp)) / n_samp
    return f, nu, np.abs(v[..., 1])


def range_spectra(x, iq: bool, n: int | None = None):
    """Fast-time FFT (length n, default the samples' count) of the compacted active chirps x (C, A, N): the
    whole spectrum for I/Q samples, the non-negative frequencies for real ones."""
    return scipy.fft.fft(x, n=n, axis=-1) if iq else scipy.fft.rfft(x, n=n, axis=-1)


def interpolate(x, chirps: Chirps, f, nu, iq, pad: int):
    """From cells to sub-bin frequencies, as a method's start does for the strongest cell (`start` on the cells of
    f, nu)."""
    n_samp, md = x.shape[-1], chirps.n_chirps
    spec = range_spectra(x, iq)
    k0 = np.clip(np.rint(f * n_samp).astype(np.int64) % n_samp, 0, spec.shape[-1] - 1)
    l0 = np.rint(nu * md).astype(np.int64) % md
    f_out, nu_out, _ = start(spec, chirps, k0, l0, n_samp, pad)
    return f_out, nu_out
