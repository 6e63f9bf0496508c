"""Range migration within a cycle, compensated per chirp, and the velocity alias it reveals.

A target at range rate V moves V T_c between chirps, so its beat walks by

    w(V) = V T_c / (range_per_hz fs)      [cycles/sample per chirp]

and chirp m holds the tone exp(j 2 pi ((f0 + w m) n + nu m)), f0 the beat of the cycle's first chirp and nu the
chirp-to-chirp phase progression 2 V T_c / lambda, which the Doppler FFT sees only modulo 1 (|V| beyond
lambda / (4 T_c) aliases). The walk, however, grows with the true V. For each alias V_k = (nu_w + k) lambda /
(2 T_c) within +-max_speed (nu_w the cell's slow-time frequency, less the tilt w (N - 1) / 2 that the walk
gives the uncompensated map), the chirps are summed coherently along that walk,

    Y_k(f) = sum_m exp(-j 2 pi nu m) X_m(f + w(V_k) m)        X_m the spectrum of chirp m (active chirps only)

and the alias whose walk integrates the most power is kept: it is the target's velocity, unaliased, and f0 its
range at the cycle's first chirp (coupling removed with V_k, not with the alias). The search reads X_m from one
zero-padded range FFT per cycle (linear interpolation between its bins); the kept alias is then refined exactly:
Newton steps on the beat of the migration-compensated sum, then on the Doppler of the per-chirp spectra at the
walking beat (spectral.newton_refine).

Limits, stated where they are measured (docs/ESTIMATION.md): neighbouring aliases differ by a walk of
2 v_max T_c M / range resolution cells over the cycle (about half a cell on AWR1642); when noise moves the
integrated power by more than that difference the neighbouring alias wins and the velocity is off by 2 v_max.
Each target is refined alone (no cancellation of the others); real (I-only) samples keep their image at -f.
"""
from __future__ import annotations

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.geometry import Geometry

PAD = 8          # zero padding of the search's range FFT
CHUNK_CYCLES = 8
DOPPLER_STEPS = 17  # the slow-time frequency is searched within +-1 Doppler bin of the cell, in 16 steps
SEARCH_BINS = 1.0   # the beat is searched within +-SEARCH_BINS FFT bins of the cell, in steps of 1 / PAD bin


def walk(geometry: Geometry, velocity_mps) -> np.ndarray:
    """Beat change per chirp [cycles/sample] of a target at range rate velocity_mps [m/s]."""
    return np.asarray(velocity_mps, dtype=float) * geometry.t_chirp_s / (geometry.range_per_hz_m * geometry.fs_hz)


def alias_folds(max_speed_mps: float, geometry: Geometry) -> np.ndarray:
    """The fold numbers k to try: every alias (nu + k) lambda / (2 T_c) of an aliased velocity that can lie
    within +-max_speed_mps."""
    step = float(geometry.velocity_from_slow_freq(1.0))
    k = int(np.ceil(max_speed_mps / step + 0.5))
    return np.arange(-k, k + 1)


def refine_walking(x, index, mask, n_chirps: int, f0, nu0, geometry: Geometry, max_speed_mps: float, *,
                   n_newton: int = 2):
    """One target per cycle along its range walk: (f at the first chirp [cycles/sample], velocity [m/s],
    amplitude per sample, normalised units), each (C,).

    x       complex64 or float32 (C, A, N): the active chirps of each cycle (rows past its count are zero)
    index   int (C, A): chirp number of each row (padding rows: silent chirps); mask bool (C, A): the row holds an
            active chirp; n_chirps the chirps of a cycle, active and silent
    f0, nu0 float (C,): the target's cell: beat [cycles/sample] and slow-time frequency [cycles/chirp]
    """
    if x.shape[0] > CHUNK_CYCLES:      # the search's padded spectra stay a few tens of MB
        parts = [refine_walking(x[i:i + CHUNK_CYCLES], index[i:i + CHUNK_CYCLES], mask[i:i + CHUNK_CYCLES], n_chirps,
                                np.asarray(f0)[i:i + CHUNK_CYCLES], np.asarray(nu0)[i:i + CHUNK_CYCLES], geometry,
                                max_speed_mps, n_newton=n_newton) for i in range(0, x.shape[0], CHUNK_CYCLES)]
        return tuple(np.concatenate(a) for a in zip(*parts))
    n_cycles, _, n_samp = x.shape
    m = np.where(mask, index, 0).astype(float)
    count = np.maximum(mask.sum(axis=1), 1)
    m_mean = (m * mask).sum(axis=1) / count
    # an alias's walk tilts the uncompensated map: over the samples n of a chirp its slow-time frequency is
    # nu + w n, so the map's cell holds nu + w (N - 1) / 2; each alias starts from its own nu
    nu_cell = np.asarray(nu0, float)
    folds = alias_folds(max_speed_mps, geometry)
    fold_speed = geometry.velocity_from_slow_freq(folds[None, :])       # one whole cycle per chirp per fold
    speeds = geometry.velocity_from_slow_freq(_wrap(nu_cell))[:, None] + fold_speed
    for _ in range(2):
        nu_k = _wrap(nu_cell[:, None] - walk(geometry, speeds) * (n_samp - 1) / 2.0)   # (C, K)
        speeds = geometry.velocity_from_slow_freq(nu_k) + fold_speed
    allowed = np.abs(speeds) <= max_speed_mps
    allowed[np.arange(n_cycles), np.argmin(np.abs(folds))] = True                        # the alias itself
    # search: Y_k(f, nu) from a zero-padded FFT of every chirp, read along each alias's walk, on a grid of beats
    # (+-SEARCH_BINS range bins) and slow-time frequencies (+-1 Doppler bin: a wrong alias's walk looks like a
    # Doppler offset of its own, so the two are searched together)
    n_fft = PAD * n_samp
    spec = scipy.fft.fft(x, n=n_fft, axis=-1)                                            # (C, A, PAD N)
    offsets = np.arange(-SEARCH_BINS * PAD, SEARCH_BINS * PAD + 1) / n_fft               # (G,)
    nus = nu_k[:, :, None] + np.linspace(-1.0, 1.0, DOPPLER_STEPS) / n_chirps            # (C, K, D)
    doppler = np.exp(-2j * np.pi * m[:, None, :, None] * nus[:, :, None, :]) * mask[:, None, :, None]   # (C,K,A,D)
    w = walk(geometry, speeds)                                                            # (C, K)
    # beat of chirp m on the fine grid: the cell's beat is the walk's mean over the active chirps
    start = np.asarray(f0, float)[:, None] - w * m_mean[:, None]                         # (C, K) f at m = 0
    pos = ((start[:, :, None, None] + offsets[None, None, :, None]
            + w[:, :, None, None] * m[:, None, None, :]) * n_fft) % n_fft                # (C, K, G, A)
    lo = np.floor(pos).astype(np.int64)
    frac = pos - lo
    lo %= n_fft        # a tiny negative position's float modulo rounds up to n_fft itself, which is bin 0
    cyc = np.arange(n_cycles)[:, None, None, None]
    row = np.arange(x.shape[1])[None, None, None, :]
    val = spec[cyc, row, lo] * (1 - frac) + spec[cyc, row, (lo + 1) % n_fft] * frac
    power = np.abs(np.matmul(val, doppler)) ** 2                                        # (C, K, G, D)
    power = np.where(allowed[:, :, None, None], power, -1.0)
    k_best, g_best, d_best = np.unravel_index(np.argmax(power.reshape(n_cycles, -1), axis=1), power.shape[1:])
    rows = np.arange(n_cycles)
    v = speeds[rows, k_best]
    f = start[rows, k_best] + offsets[g_best]
    nu_start = nus[rows, k_best, d_best]
    doppler = np.exp(-2j * np.pi * nu_start[:, None] * m) * mask                        # (C, A)
    # exact refinement along the kept walk: the beat of the compensated sum, then the Doppler at the walking beat
    wk = walk(geometry, v)
    comp = spectral.phasor(wk[:, None] * m, n_samp)                                      # (C, A, N)
    y = np.einsum("ca,can->cn", doppler, x * comp)
    f = spectral.newton_refine(y, f, n_iter=n_newton, max_step=1.0 / (PAD * n_samp))
    z = np.einsum("can,can->ca", x, comp * spectral.phasor(f, n_samp)[:, None, :])       # chirp spectra at f + w m
    z_full = np.zeros((n_cycles, n_chirps), dtype=complex)
    z_full[rows[:, None], index] = np.where(mask, z, 0)     # padding rows name silent chirps: no index twice
    nu = spectral.newton_refine(z_full, nu_start, n_iter=n_newton, times=np.arange(z_full.shape[1], dtype=float))
    v = v + geometry.velocity_from_slow_freq(nu - nu_k[rows, k_best])
    amp = np.abs((z_full * spectral.phasor(nu, z_full.shape[1])).sum(axis=1)) / (n_samp * count)
    return f, v, amp


def _wrap(nu):
    return (nu + 0.5) % 1.0 - 0.5
