"""What every estimation method shares: the result type, the input checks, the active chirps compacted and scaled,
and the two single-precision sums every refinement reads the samples through.

Only the active chirps (rho True) are read: they are gathered into (C, A, N), A the largest active count of the
batch (shorter cycles padded with zero rows); slow-time results scatter them back to their chirp times with zeros
at the silent ones, which is exactly the non-uniform DFT of the sparse active set.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from carav_stream.estimate import spectral
from carav_stream.estimate.geometry import Geometry


@dataclass(frozen=True)
class Estimates:
    """Per-cycle target estimates; NaN where nothing was found.

    range_m       float64 (n_cycles, n_targets)  range, range-Doppler coupling removed [m]
    velocity_mps  float64 (n_cycles, n_targets)  radial velocity, positive receding, in (-v_max, v_max] [m/s]
    beat_hz       float64 (n_cycles, n_targets)  beat frequency as measured (Doppler included) [Hz]
    amplitude     float64 (n_cycles, n_targets)  tone amplitude per sample, input units (real samples: the
                                                 amplitude a of a cos(.))
    n_found       int64 (n_cycles,)              number of targets reported in the cycle
    method        str
    """

    range_m: np.ndarray
    velocity_mps: np.ndarray
    beat_hz: np.ndarray
    amplitude: np.ndarray
    n_found: np.ndarray
    method: str


def check_inputs(frames, rho, geometry: Geometry, lsb: float | None = None):
    """frames and rho as arrays, checked against the geometry; with `lsb`, frames are an ADC's int16 codes
    (n_cycles, n_chirps, n_samples), I/Q with a last axis of 2 (I, Q), as carav_stream.radar.adc delivers them."""
    if not isinstance(geometry, Geometry):
        raise TypeError(f"estimate: geometry must be a Geometry, got {type(geometry).__name__}")
    frames = np.asarray(frames)
    shape = frames.shape
    if lsb is not None:
        if frames.dtype != np.int16:
            raise TypeError(f"estimate: with lsb, frames must be an ADC's int16 codes, got {frames.dtype}")
        if not lsb > 0 or not np.isfinite(lsb):
            raise ValueError(f"estimate: lsb must be a finite step above 0, got {lsb!r}")
        if geometry.iq and (frames.ndim != 4 or shape[-1] != 2):
            raise ValueError(f"estimate: I/Q codes must be (n_cycles, n_chirps, n_samples, 2), got shape {shape}")
        shape = shape[:3] if geometry.iq else shape
    elif np.iscomplexobj(frames) != geometry.iq:
        kind = "complex" if np.iscomplexobj(frames) else "real"
        raise ValueError(f"estimate: frames are {kind} ({frames.dtype}) but geometry.iq is {geometry.iq}")
    if len(shape) != 3:
        raise ValueError(f"estimate: frames must be (n_cycles, n_chirps, n_samples), got shape {frames.shape}")
    if shape[-1] != geometry.n_samples:
        raise ValueError(f"estimate: frames have {shape[-1]} samples per chirp, geometry.n_samples is "
                         f"{geometry.n_samples}")
    rho = np.asarray(rho)
    if rho.dtype != bool:
        raise TypeError(f"estimate: rho must be bool (n_cycles, n_chirps), got dtype {rho.dtype}")
    if rho.shape != shape[:2]:
        raise ValueError(f"estimate: rho has shape {rho.shape}, expected frames.shape[:2] = {shape[:2]}")
    return frames, rho


@dataclass(frozen=True)
class Chirps:
    """The active chirps of every cycle, compacted: arrays (C, A, ...) with A the most active chirps in any cycle
    (at least 1) hold in row a of cycle c chirp index[c, a] for a < count[c]; the rows after them are padding
    (mask False) and are zero in every compacted array."""

    rho: np.ndarray  # (C, M) bool: the activation pattern
    index: np.ndarray  # (C, A) int: active chirps in increasing order, then silent ones (padding)
    mask: np.ndarray  # (C, A) bool: row holds an active chirp
    count: np.ndarray  # (C,) int: active chirps per cycle

    @classmethod
    def of(cls, rho):
        count = rho.sum(axis=1)
        k = max(int(count.max(initial=0)), 1)
        index = np.argsort(~rho, axis=1, kind="stable")[:, :k]
        return cls(rho=rho, index=index, mask=np.arange(k) < count[:, None], count=count)

    @property
    def n_chirps(self) -> int:
        return self.rho.shape[1]

    def gather(self, a):
        """(C, M, ...) -> (C, A, ...): the active chirps' rows, padding rows zero."""
        out = a[np.arange(a.shape[0])[:, None], self.index]
        if not self.mask.all():
            out[~self.mask] = 0
        return out

    def scatter(self, b):
        """(C, A, ...) -> (C, M, ...): the rows back at their chirps, zero at the silent ones."""
        out = np.zeros((b.shape[0], self.n_chirps) + b.shape[2:], dtype=b.dtype)
        out[np.arange(b.shape[0])[:, None], self.index] = b  # padding rows are zero and land on silent chirps
        return out


def normalise(frames, chirps: Chirps, lsb: float | None = None):
    """Gather the active chirps, drop non-finite cycles, scale each cycle to unit peak |I| or |Q|.

    Returns x (C, A, N) complex64 or float32 (compacted, see Chirps), scale (C,) float64 and valid (C,) bool.
    Silent chirps are never read, whatever they hold. With `lsb`, frames are int16 ADC codes (check_inputs):
    the active chirps' codes are gathered first and turned into samples there, code * float32(lsb) as
    radar.adc.from_codes does (the same float32 values, from half the chirps and half the bytes gathered).
    Cost: the ranging stage in docs/bench/pipeline.md."""
    if lsb is None:
        x = chirps.gather(frames).astype(np.complex64 if np.iscomplexobj(frames) else np.float32, copy=False)
    else:
        x = np.multiply(chirps.gather(frames), np.float32(lsb), dtype=np.float32)
        if x.ndim == 4:                                   # I/Q codes: (..., 2) -> complex64
            x = x.view(np.complex64)[..., 0]
    flat = x.view(np.float32).reshape(x.shape[0], -1)
    peak = np.maximum(flat.max(axis=1), -flat.min(axis=1)).astype(float)  # NaN/inf propagate here
    valid = np.isfinite(peak) & (peak > 0) & (chirps.count > 0)
    scale = np.where(valid, peak, 1.0)
    x *= (1.0 / scale).astype(np.float32)[:, None, None]
    x[~valid] = 0
    return x, scale, valid


@functools.lru_cache(maxsize=16)
def turns(n: int, dtype) -> np.ndarray:
    """exp(-j 2 pi i / n), i = 0..n-1, read-only of dtype: the phases of a DFT of length n, looked up by integer."""
    out = np.exp((-2j * np.pi / n) * np.arange(n)).astype(dtype)
    out.flags.writeable = False
    return out


def integrate_fast(x, chirps: Chirps, nu):
    """Doppler-compensated coherent sum over active chirps: y[c, n] = sum_m x[c,m,n] exp(-j 2 pi nu_c m).

    x compacted complex64 or float32 (C, A, N), single-precision products (the data's precision); returns
    complex128 (C, N)."""
    e = chirps.gather(spectral.phasor(nu, chirps.n_chirps))  # (C, A), zero on padding rows
    if np.iscomplexobj(x):
        return np.matmul(e.astype(np.complex64)[:, None, :], x)[:, 0, :].astype(np.complex128)
    c = e.real.astype(np.float32)[:, None, :]  # two matrix-vector products beat one with two columns
    s = e.imag.astype(np.float32)[:, None, :]
    return np.matmul(c, x)[:, 0, :] + 1j * np.matmul(s, x)[:, 0, :].astype(np.float64)


def demod_slow(x, chirps: Chirps, f, gate=None):
    """Per-chirp DTFT at beat f [cycles/sample]: z[c, m] = sum_n g[c, n] x[c,m,n] exp(-j 2 pi f_c n), complex128
    (C, M) (zero at silent chirps), from the compacted x (C, A, N); the weights g (C, N) are `gate`, or 1."""
    e = spectral.phasor(f, x.shape[-1])
    if gate is not None:
        e = e * gate
    if np.iscomplexobj(x):
        z = np.matmul(x, e.astype(np.complex64)[:, :, None])[:, :, 0].astype(np.complex128)
    else:
        c = e.real.astype(np.float32)[:, :, None]
        s = e.imag.astype(np.float32)[:, :, None]
        z = np.matmul(x, c)[:, :, 0] + 1j * np.matmul(x, s)[:, :, 0].astype(np.float64)
    return chirps.scatter(z)
