"""The range-Doppler power map of the active chirps (a pure kernel): what the spectral test and the radar's CFAR
target detection (carav_stream/firmware/cfar.py) look at.

Silent chirps are zeroed (the detector has judged the cycle clean; only the active chirps carry echoes),
each chirp is windowed (Hann, so that a strong target's range sidelobes fall to -31 dB instead of the
rectangular window's -13 dB) and transformed in fast time (all N bins for I/Q; bins 1..ceil(N/2)-1 of the real
FFT for I-only: DC and Nyquist have another law), then in slow time over the M chirp slots:

    P[c, l, k] = |sum_{m active} X_m[k] exp(-j 2 pi l m / M)|^2 / (A_c sum(w^2) sigma_n^2)

A_c the active chirps of cycle c, w the window. Under white Gaussian noise every cell is exactly Exp(1), whatever
the activation pattern: X_m[k] is circular Gaussian with variance sum(w^2) sigma_n^2, and the slow-time sum has
A_c unit-modulus weights. The window correlates neighbouring range bins: Hann's bin is 0.5 X[k] - 0.25 X[k-1]
- 0.25 X[k+1] of the unwindowed ones, so bins 1 and 2 apart are correlated (coefficients -2/3 and 1/6) and bins
3 or more apart are independent. Cells of one range bin are correlated across Doppler (a sparse, non-uniform
slow-time sampling is not an orthogonal transform), but never with other range bins 3 or more away.
"""
from __future__ import annotations

import numpy as np
import scipy.fft  # scipy.signal loads on first use (scipy's lazy submodules), not in every process importing this

__all__ = ["rd_power"]


def rd_power(frames, rho, sigma_n: float, *, single: bool = False) -> np.ndarray:
    """Normalised range-Doppler power map, float64 (n_cycles, n_chirps, n_range_bins): Exp(1) per cell under noise.

    frames  float32/64 (I-only) or complex64/128 (I/Q), (n_cycles, n_chirps, n_samples)
    rho     bool (n_cycles, n_chirps) activation (silent chirps are ignored)
    single  compute in single precision and return float32 (the radar's target list: faster, and a
            cell's power is then good to 1e-7 relative, far below what moves a CFAR decision)
    Range bin j of the map is FFT bin j (I/Q) or j + 1 (I-only, DC dropped).
    """
    x = np.asarray(frames)
    r = np.asarray(rho, dtype=bool)
    if x.ndim != 3 or r.shape != x.shape[:2]:
        raise ValueError(f"frames {x.shape} and rho {r.shape}: expected (cycles, chirps, samples) and (cycles, chirps)")
    if not sigma_n > 0:
        raise ValueError(f"sigma_n: must be > 0, got {sigma_n!r}")
    n_s = x.shape[-1]
    active = r.sum(axis=1)
    if np.any(active == 0):
        raise ValueError("rho: a cycle without active chirps has no range-Doppler map")
    w = scipy.signal.windows.hann(n_s, sym=False)
    real = np.float32 if single else np.float64
    # the range FFT of the active chirps only (gathered), scattered back into slow time with zeros at the silent
    rows = np.argsort(~r, axis=1, kind="stable")[:, :int(active.max())]
    cyc = np.arange(x.shape[0])[:, None]
    wx = x[cyc, rows] * w.astype(real)
    if np.iscomplexobj(x):
        part = scipy.fft.fft(wx, axis=-1, overwrite_x=True)
    else:
        part = scipy.fft.rfft(wx, axis=-1)[..., 1: (n_s + 1) // 2]   # drop DC (and Nyquist for even N)
    part[~np.take_along_axis(r, rows, axis=1)] = 0                   # padding rows of cycles with fewer actives
    spec = np.zeros((x.shape[0], x.shape[1], part.shape[-1]), dtype=part.dtype)
    spec[cyc, rows] = part
    rd = scipy.fft.fft(spec, axis=1, overwrite_x=True)
    power = rd.real.astype(real) ** 2 + rd.imag.astype(real) ** 2
    power *= (1.0 / (active * float(w @ w) * sigma_n ** 2)).astype(real)[:, None, None]
    return power
