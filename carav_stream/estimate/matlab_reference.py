"""MATLAB phased-array toolbox FMCWExample processing chain, rewritten from its published steps.

    xr_d   = decimate(xr, Dn, 'FIR')                       fast time, Dn = 2 for table1 (150 -> 75 MHz)
    fb     = rootmusic(pulsint(xr_d, 'coherent'), 1, fs_d)  plain sum over sweeps, model order 1
    R      = beat2range(fb, slope) = c fb / (2 slope)       (no range-Doppler correction)
    row    = val2ind(R, c / (2 fs_d))                        one fast-time sample index
    fd     = -rootmusic(xr_d(row, :), 1, 1 / t_m)            slow time across sweeps
    v      = dop2speed(fd, lambda) / 2 = fd lambda / 2       closing speed (positive approaching)

MATLAB's rootmusic on a vector with signal-subspace dimension p uses windows of length 2p (overlap 2p - 1)
and no forward-backward averaging; here p = 1, a 2 x 2 covariance. Published table1 result:
R = 42.9976 m, v = 1.0830 m/s against the true 43 m and 1.111 m/s (MATLAB_TABLE1_*).
"""
from __future__ import annotations

import numpy as np
import scipy.signal

from carav_stream.core.units import C_MPS, KMH
from carav_stream.estimate import spectral
from carav_stream.estimate.geometry import Geometry


def fmcw_example_geometry() -> Geometry:
    """The FMCWExample waveform (the paper's Table I), from MATLAB's published formulas rather than the rounded
    preset: range_max 200 m, t_m = 5.5 * 2 * 200 / c = 7.34 us, bandwidth c / 2 (1 m resolution) = 149.9 MHz,
    fs = 150 MHz; 1100 complex samples per sweep."""
    t_m = 5.5 * 2.0 * 200.0 / C_MPS
    bw = C_MPS / 2.0
    return Geometry(fs_hz=150e6, slope_hz_per_s=bw / t_m, fc_hz=77e9, t_chirp_s=t_m, n_samples=1100, iq=True)


MATLAB_TABLE1_RANGE_M = 42.9976
MATLAB_TABLE1_CLOSING_SPEED_MPS = 1.0830
TABLE1_TRUE_RANGE_M = 43.0
TABLE1_TRUE_CLOSING_SPEED_MPS = (100.0 - 96.0) * KMH


def rootmusic_vector(x, n_signal: int = 1):
    """MATLAB-style rootmusic of vectors x (..., N): covariance of sliding windows of length 2 n_signal.

    Returns frequencies [cycles/sample] (..., n_signal)."""
    length = 2 * n_signal
    h = np.lib.stride_tricks.sliding_window_view(np.asarray(x, dtype=complex), length, axis=-1)
    cov = np.einsum("...si,...sj->...ij", h, h.conj()) / h.shape[-2]
    _, sig = spectral.subspaces(cov, n_signal)
    freq, _ = spectral.root_music_roots(sig, n_signal)
    return freq


def fmcw_example_estimate(frames, geometry: Geometry, *, decimation: int = 2) -> dict[str, np.ndarray]:
    """Run the FMCWExample chain on every cycle of frames (n_cycles, n_chirps, n_samples) complex.

    All chirps are used (FMCWExample has no silencing). Returns dict of (n_cycles,) float arrays:
    beat_hz, range_m (beat-only, as MATLAB reports it), closing_speed_mps (MATLAB's sign) and
    velocity_mps (= -closing speed, this package's sign).
    """
    frames = np.asarray(frames)
    if not np.iscomplexobj(frames) or frames.ndim != 3:
        raise ValueError(f"fmcw_example_estimate: frames must be complex (n_cycles, n_chirps, n_samples), got "
                         f"{frames.dtype} {frames.shape}")
    x = frames.astype(np.complex128)
    if decimation > 1:
        x = scipy.signal.decimate(x, decimation, ftype="fir", axis=-1)
    fs_d = geometry.fs_hz / decimation
    integrated = x.sum(axis=1)
    beat_hz = (rootmusic_vector(integrated, 1)[:, 0] % 1.0) * fs_d
    range_m = C_MPS * beat_hz / (2.0 * geometry.slope_hz_per_s)
    row = np.clip(np.round(range_m / (C_MPS / (2.0 * fs_d))).astype(int), 0, x.shape[-1] - 1)
    slow = x[np.arange(x.shape[0]), :, row]  # (n_cycles, n_chirps)
    fd_hz = -rootmusic_vector(slow, 1)[:, 0] / geometry.t_chirp_s
    closing = fd_hz * geometry.wavelength_m / 2.0
    return {"beat_hz": beat_hz, "range_m": range_m, "closing_speed_mps": closing, "velocity_mps": -closing}
