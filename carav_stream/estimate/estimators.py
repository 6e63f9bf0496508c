"""Target estimation of Algorithm 1, step 6: range and radial velocity from the active chirps of clean cycles.

Pipeline, vectorised over cycles (C cycles, M chirps, N fast-time samples):
1. Only the active chirps (rho True) are read: they are gathered into (C, A, N), A the largest active count
   of the batch (shorter cycles padded with zero rows), and every sum and fast-time FFT below runs on them.
   Slow-time spectra scatter them back to their chirp times with zeros at the silent ones, which is exactly
   the non-uniform DFT of the sparse active set.
2. Range-Doppler map |FFT_slow(FFT_fast(x))|^2 (fast-time FFT length nr, slow-time length md), transformed in
   slow time only at the range bins that can hold its maximum (a bound from each bin's energy); targets are
   the K largest local maxima (K given, or estimated by MDL/AIC on a Toeplitz covariance built from the
   non-coherently integrated power spectrum of the active chirps).
3. Refinement by method:
     fft_peak      grid peak (bin centres)
     fft_zeropad   zero-padded grid (zeropad x in range, 4x in Doppler) + parabolic interpolation of |D|
     fft_interp    parabolic vertex of |RD| along the peak's range bin on an 8x zero-padded Doppler FFT, then
                   Candan's bias-corrected three-bin interpolation in range at that Doppler
     ml            fft_interp (2x padding: a start), then safeguarded Newton steps on the 2-D periodogram
                   |sum_{m active} sum_n x[m,n] exp(-j 2 pi (f n + nu m))|^2. One target: joint steps in (f, nu),
                   each one pass over the samples (per-chirp DTFT moments, then sums over the active chirp
                   times; joint.py), the image of real samples removed in closed form. Several targets:
                   alternating steps, Doppler-compensated coherent integration over the active chirps for the
                   beat f and the non-uniform slow-time periodogram (sparse chirp times) for nu, the others and
                   the images removed by RELAX-style cancellation
     music         Doppler-compensated coherent integration over the active chirps, forward-backward smoothed
                   covariance (subvector length L), MUSIC pseudo-spectrum on a fine grid around the FFT peak
     root_music    as music, frequency from the roots of the root-MUSIC polynomial (model order doubles for
                   real I-only samples)
   Doppler for music / root_music: Newton on the non-uniform slow-time periodogram at the refined beat.
4. Range with range-Doppler coupling removed: R = c/(2S) (f_b - 2 v / lambda)   (see geometry.py)

Inputs are scaled per cycle by their largest magnitude first, so amplitudes of 1e-30 and noise-free frames
(rank-deficient covariances) are handled; cycles without active chirps, with non-finite samples or with no
energy give NaN.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.fft

from carav_stream.estimate import joint, spectral
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.migration import refine_walking

METHODS = ("fft_peak", "fft_zeropad", "fft_interp", "music", "root_music", "ml")
DEFAULT_METHOD = "ml"


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


def _check_inputs(frames, rho, geometry: Geometry, method: str, lsb: float | None = None):
    """frames and rho as arrays, checked against the geometry; with `lsb`, frames are an ADC's int16 codes
    (n_cycles, n_chirps, n_samples), I/Q with a last axis of 2 (I, Q), as carav_stream.radar.adc delivers them."""
    if method not in METHODS:
        raise ValueError(f"estimate: method must be one of {METHODS}, got {method!r}")
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
class _Chirps:
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


def _normalise(frames, chirps: _Chirps, lsb: float | None = None):
    """Gather the active chirps, drop non-finite cycles, scale each cycle to unit peak |I| or |Q|.

    Returns x (C, A, N) complex64 or float32 (compacted, see _Chirps), scale (C,) float64 and valid (C,) bool.
    Silent chirps are never read, whatever they hold. With `lsb`, frames are int16 ADC codes (_check_inputs):
    the active chirps' codes are gathered first and turned into samples there, code * float32(lsb) as
    radar.adc.from_codes does (the same float32 values, for half the chirps and half the bytes gathered: the
    conversion and compaction of a table1 frame of 32 cycles cost about 17 us a cycle instead of 55 from all the
    samples, on an AMD EPYC, Zen 4, with the nodes' allocator settings)."""
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


def _estimate_order(x, chirps: _Chirps, criterion: str, max_targets: int, iq: bool):
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


def _search(spec, chirps: _Chirps, md: int, iq: bool):
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


def _cells(spec, chirps: _Chirps, l, k, md: int):
    """Range-Doppler values RD[l, k] = sum_m spec[m, k] exp(-j 2 pi l m / md) at the cells (l, k), each (C, J)
    (l any integer, k in range), complex128 (C, J)."""
    col = np.take_along_axis(spec, k[:, None, :], axis=2).astype(complex)  # (C, A, J)
    turns = (chirps.index[:, :, None] * l[:, None, :]) % md / md  # exact integer phase
    return (col * np.exp(-2j * np.pi * turns) * chirps.mask[:, :, None]).sum(axis=1)


def _start(spec, chirps: _Chirps, k0, l0, n_samp: int, pad: int):
    """Sub-bin start (f [cycles/sample], nu [cycles/chirp], |RD| there), each (C, K), of the targets at the cells
    (l0, k0) (C, K) of the compacted range spectra spec (C, A, nb).

    nu: the parabolic vertex of |RD| along range bin k0 on a pad-times zero-padded Doppler FFT, at its global
    maximum for one target (robust to the high sidelobes of the sparse active set when the coarse grid scallops),
    within one coarse bin of l0 for several. f: Candan's three-bin interpolation across bins k0 - 1, k0, k0 + 1
    (clipped to the spectrum) at that padded Doppler cell (exact integer phases; n_samp the unpadded length).
    pad (_start_pad): 8 where nu is the answer (fft_interp: a coarser grid's parabolic vertex is biased at high
    SNR), 2 where it is a start (ml: RMSE / CRLB within 1.05 from 0 to 30 dB on both presets, as with 4 or 8; with 1,
    the coarse grid, one Newton step no longer reaches the bound: 16 to 166 x the CRLB in velocity on table1 from 10
    to 30 dB, carav bench estimators --estimators fft_peak,ml at 500 cycles)."""
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
    e = _turns(n_pad, spec.dtype)[(chirps.index[:, None, :] * j[..., None]) % n_pad]  # (C, K, A)
    v = np.matmul(rows, e[..., None])[..., 0].astype(complex)  # (C, K, 3): a product per cycle
    f = (k0 + spectral.candan_delta(v[..., 0], v[..., 1], v[..., 2], n_samp)) / n_samp
    return f, nu, np.abs(v[..., 1])


@functools.lru_cache(maxsize=16)
def _turns(n: int, dtype) -> np.ndarray:
    """exp(-j 2 pi i / n), i = 0..n-1, read-only of dtype: the phases of a DFT of length n, looked up by integer."""
    out = np.exp((-2j * np.pi / n) * np.arange(n)).astype(dtype)
    out.flags.writeable = False
    return out


def _integrate_fast(x, chirps: _Chirps, nu):
    """Doppler-compensated coherent sum over active chirps: y[c, n] = sum_m x[c,m,n] exp(-j 2 pi nu_c m).

    x compacted complex64 or float32 (C, A, N), single-precision products (the data's precision); returns
    complex128 (C, N)."""
    e = chirps.gather(spectral.phasor(nu, chirps.n_chirps))  # (C, A), zero on padding rows
    if np.iscomplexobj(x):
        return np.matmul(e.astype(np.complex64)[:, None, :], x)[:, 0, :].astype(np.complex128)
    c = e.real.astype(np.float32)[:, None, :]  # two matrix-vector products beat one with two columns
    s = e.imag.astype(np.float32)[:, None, :]
    return np.matmul(c, x)[:, 0, :] + 1j * np.matmul(s, x)[:, 0, :].astype(np.float64)


def _demod_slow(x, chirps: _Chirps, f):
    """Per-chirp DTFT at beat f [cycles/sample]: z[c, m] = sum_n x[c,m,n] exp(-j 2 pi f_c n), complex128 (C, M)
    (zero at silent chirps), from the compacted x (C, A, N)."""
    e = spectral.phasor(f, x.shape[-1])
    if np.iscomplexobj(x):
        z = np.matmul(x, e.astype(np.complex64)[:, :, None])[:, :, 0].astype(np.complex128)
    else:
        c = e.real.astype(np.float32)[:, :, None]
        s = e.imag.astype(np.float32)[:, :, None]
        z = np.matmul(x, c)[:, :, 0] + 1j * np.matmul(x, s)[:, :, 0].astype(np.float64)
    return chirps.scatter(z)


def _music_beat(y, f_init, n_model: int, length: int, root: bool, n_bins: int):
    """Beat [cycles/sample] nearest f_init from (root-)MUSIC on y (C, N)."""
    cov = spectral.fb_covariance(y, length)
    _, sig = spectral.subspaces(cov, n_model)
    if root:
        cand, _ = spectral.root_music_roots(sig, n_model)
        d = (cand - f_init[:, None] + 0.5) % 1.0 - 0.5
        pick = np.argmin(np.abs(d), axis=1)
        return f_init + np.take_along_axis(d, pick[:, None], axis=1)[:, 0]
    # spectral MUSIC on a fine grid of +-1 FFT bin around the interpolated peak, then a parabolic vertex
    n_grid = 129
    offs = np.linspace(-1.0, 1.0, n_grid) / n_bins
    grid = f_init[:, None] + offs  # (C, G)
    a = np.exp(2j * np.pi * grid[:, :, None] * np.arange(length))  # (C, G, L)
    proj = np.abs(np.matmul(a, sig.conj())) ** 2  # (C, G, K)  |e^H a|^2 = |a^T e*|^2
    pseudo = 1.0 / np.maximum(length - proj.sum(axis=-1), length * 1e-15)
    k = np.clip(np.argmax(pseudo, axis=1), 1, n_grid - 2)
    lp = np.log(np.take_along_axis(pseudo, np.stack([k - 1, k, k + 1], axis=1), axis=1))
    delta = spectral.parabolic_delta(lp[:, 0], lp[:, 1], lp[:, 2])
    return f_init + (offs[k] + delta * (offs[1] - offs[0]))


def _one_target(x, chirps: _Chirps, method, zeropad, n_newton, music_length, iq):
    """Strongest target of every cycle from the compacted x (C, A, N): (f, nu, amp) each (C, 1); f
    [cycles/sample], nu [cycles/chirp], amp the positive-frequency tone amplitude per sample (normalised units)."""
    n_samp = x.shape[-1]
    nr = n_samp * (zeropad if method == "fft_zeropad" else 1)
    md = chirps.n_chirps * (4 if method == "fft_zeropad" else 1)
    # range FFT of the active chirps only (the silent ones are zero)
    spec = scipy.fft.fft(x, n=nr, axis=-1) if iq else scipy.fft.rfft(x, n=nr, axis=-1)
    nb = spec.shape[-1]
    l0, k0 = _search(spec, chirps, md, iq)  # (C, 1) Doppler and range bins
    f = k0 / nr
    nu = l0 / md
    if method == "fft_zeropad":
        k3 = np.concatenate([np.clip(k0 - 1, 0, nb - 1), k0, np.clip(k0 + 1, 0, nb - 1), k0, k0], axis=1)
        l3 = np.concatenate([l0, l0, l0, l0 - 1, l0 + 1], axis=1)
        mag = np.abs(_cells(spec, chirps, l3, k3, md))
        f = f + spectral.parabolic_delta(mag[:, 0:1], mag[:, 1:2], mag[:, 2:3]) / nr
        nu = nu + spectral.parabolic_delta(mag[:, 3:4], mag[:, 1:2], mag[:, 4:5]) / md
        peak = mag[:, 1:2]
    elif method != "fft_peak":
        f, nu, peak = _start(spec, chirps, k0, l0, n_samp, _start_pad(method))
    else:
        peak = np.abs(_cells(spec, chirps, l0, k0, md))
    amp = peak / (n_samp * np.maximum(chirps.count, 1))[:, None]
    if method in ("ml", "music", "root_music"):
        f, nu, amp = _refine(x, chirps, f, nu, amp, method, n_newton, music_length, iq)
    return f, nu, amp


def estimate(frames, rho, geometry: Geometry, *, method: str = DEFAULT_METHOD, n_targets: int | None = 1,
             max_targets: int = 4, criterion: str = "mdl", zeropad: int = 8, music_length: int | None = None,
             n_newton: int = 1, couple: bool = True, max_speed_mps: float = 0.0,
             lsb: float | None = None) -> Estimates:
    """Range and velocity of up to n_targets targets per cycle from the active chirps.

    frames        (n_cycles, n_chirps, n_samples) complex64 (geometry.iq) or float32 ADC samples
    rho           bool (n_cycles, n_chirps): chirps that transmitted in each cycle
    geometry      Geometry of the waveform
    method        one of METHODS
    n_targets     targets per cycle, or None to estimate it per cycle with `criterion` ('mdl' | 'aic'),
                  capped at max_targets (output width = largest estimate, at least 1)
    zeropad       fast-time zero-padding factor of fft_zeropad
    music_length  MUSIC subvector length L (default min(N // 4, 32))
    n_newton      Newton steps per refinement (ml, and the Doppler stage of music / root_music)
    couple        remove the range-Doppler coupling from range_m (beat_hz is always the raw beat)
    max_speed_mps > 0: range migration compensated: the fft_peak cells of the strongest maxima, each refined along
                  its range walk (refine_at), velocities unaliased within +-max_speed_mps (method ignored)
    lsb           the ADC's step: frames are then its int16 codes (I/Q: a last axis of 2, I then Q), the samples
                  code * lsb (radar.adc.from_codes), converted for the active chirps only; the same result
    Returns Estimates; raises ValueError/TypeError naming the bad argument.
    """
    if max_speed_mps > 0:
        cells = estimate(frames, rho, geometry, method="fft_peak", n_targets=n_targets, max_targets=max_targets,
                         criterion=criterion, couple=False, lsb=lsb)
        return refine_at(frames, rho, geometry, cells.beat_hz / geometry.fs_hz,
                         geometry.slow_freq_from_velocity(cells.velocity_mps), couple=couple,
                         max_speed_mps=max_speed_mps, lsb=lsb)
    frames, rho = _check_inputs(frames, rho, geometry, method, lsb)
    if n_targets is not None and (int(n_targets) != n_targets or n_targets < 1):
        raise ValueError(f"estimate: n_targets must be a positive integer or None, got {n_targets!r}")
    if int(zeropad) != zeropad or zeropad < 1:
        raise ValueError(f"estimate: zeropad must be a positive integer, got {zeropad!r}")
    n_cycles, n_chirps, n_samp = frames.shape[:3]
    iq = geometry.iq
    chirps = _Chirps.of(rho)
    x, scale, valid = _normalise(frames, chirps, lsb)  # (C, A, N): the active chirps only

    if n_targets is None:
        order = np.where(valid, _estimate_order(x, chirps, criterion, max_targets, iq), 0)
        width = max(int(order.max(initial=0)), 1)
    else:
        width = int(n_targets)
        order = np.where(valid, width, 0)

    if width == 1:
        f, nu, amp = _one_target(x, chirps, method, zeropad, n_newton, music_length, iq)
    else:
        # RELAX-style sequential search: the strongest target first, removed from the data before the next
        # search (its range and Doppler sidelobes -- high for a sparse active set -- would otherwise win),
        # then joint refinement of all targets with the others cancelled
        f = np.zeros((n_cycles, width))
        nu = np.zeros((n_cycles, width))
        amp = np.zeros((n_cycles, width))
        resid = x.copy()
        n_act = np.maximum(chirps.count, 1)
        for k in range(width):
            fk, nuk, _ = _one_target(resid, chirps, method, zeropad, n_newton, music_length, iq)
            f[:, k], nu[:, k] = fk[:, 0], nuk[:, 0]
            slow = spectral.phasor(nu[:, k], n_chirps) * rho
            alpha = (_demod_slow(resid, chirps, f[:, k]) * slow).sum(axis=1) / (n_samp * n_act)  # e^{+j..}
            amp[:, k] = np.abs(alpha)
            tone = (alpha[:, None] * chirps.gather(slow.conj()))[:, :, None] * \
                spectral.phasor(f[:, k], n_samp, +1.0)[:, None, :]
            resid = resid - (tone if iq else 2.0 * tone.real).astype(resid.dtype)  # real: a e^{..} + conj
        if method in ("ml", "music", "root_music"):
            f, nu, amp = _refine(x, chirps, f, nu, amp, method, n_newton, music_length, iq)

    found = np.arange(width)[None, :] < order[:, None]
    return _estimates(f, nu, amp, found, scale, chirps, geometry, method, couple)


def _estimates(f, nu, amp, found, scale, chirps: _Chirps, geometry: Geometry, method: str, couple: bool) -> Estimates:
    """Normalised (f, nu, amp) (C, K) -> Estimates in physical units; NaN where `found` is False."""
    nu = (nu + 0.5) % 1.0 - 0.5
    beat_hz = (f % 1.0) * geometry.fs_hz
    velocity = geometry.velocity_from_slow_freq(nu)
    one_chirp = chirps.count < 2
    velocity = np.where(one_chirp[:, None], np.nan, velocity)
    range_m = geometry.range_from_beat(beat_hz, np.nan_to_num(velocity) if couple else 0.0)
    nan = np.nan
    return Estimates(range_m=np.where(found, range_m, nan), velocity_mps=np.where(found, velocity, nan),
                     beat_hz=np.where(found, beat_hz, nan),
                     amplitude=np.where(found, amp * (scale[:, None] * (1.0 if geometry.iq else 2.0)), nan),
                     n_found=found.sum(axis=1).astype(np.int64), method=method)


def refine_at(frames, rho, geometry: Geometry, f0, nu0, *, method: str = DEFAULT_METHOD, n_newton: int = 1,
              music_length: int | None = None, couple: bool = True, max_speed_mps: float = 0.0,
              lsb: float | None = None) -> Estimates:
    """Targets found elsewhere (a CFAR list, say) refined by `method` from where they were found.

    f0, nu0   float (n_cycles, K): beat [cycles/sample] and slow-time frequency [cycles/chirp] of each target
              (its cell), NaN after the last target of a cycle (targets first, padding after)
    ml, music and root_music refine every target of a cycle jointly (the others cancelled, as in `estimate`);
    fft_peak keeps the cells. Amplitudes are measured at the final frequencies.
    max_speed_mps > 0: every target is refined alone along its range walk instead (estimate/migration.py): the
    velocity alias within +-max_speed_mps whose walk integrates most power is kept, so velocities are unaliased
    and ranges refer to the cycle's first chirp, coupling removed with the unaliased velocity (method ignored).
    lsb: frames are ADC codes, as in `estimate`.
    """
    if max_speed_mps > 0:
        return _refine_walking(frames, rho, geometry, f0, nu0, max_speed_mps, couple, lsb)
    frames, rho = _check_inputs(frames, rho, geometry, method, lsb)
    f0, nu0 = np.asarray(f0, dtype=float), np.asarray(nu0, dtype=float)
    if f0.ndim != 2 or f0.shape != nu0.shape or f0.shape[0] != frames.shape[0]:
        raise ValueError(f"refine_at: f0 {f0.shape} and nu0 {nu0.shape} must be (n_cycles, K) for "
                         f"{frames.shape[0]} cycles")
    present = np.isfinite(f0) & np.isfinite(nu0)
    counts = present.sum(axis=1)
    if not np.array_equal(present, np.arange(f0.shape[1])[None, :] < counts[:, None]):
        raise ValueError("refine_at: every cycle lists its targets first, NaN padding after")
    chirps = _Chirps.of(rho)
    _, scale, valid = _normalise(frames, chirps, lsb)
    f, nu, amp = np.where(present, f0, 0.0), np.where(present, nu0, 0.0), np.zeros(f0.shape)
    for k in np.unique(counts[counts > 0]):      # cycles with the same number of targets refine together
        rows = np.flatnonzero(counts == k)
        sub = _Chirps.of(rho[rows])
        x, _, _ = _normalise(frames[rows], sub, lsb)
        fs, nus = f[rows, :k], nu[rows, :k]
        if method != "fft_peak":
            fs, nus = _interpolate(x, sub, fs, nus, geometry.iq, _start_pad(method))
        if method in ("ml", "music", "root_music"):
            fs, nus, amps = _refine(x, sub, fs, nus, None, method, n_newton, music_length, geometry.iq)
        else:
            amps = np.stack([np.abs((_demod_slow(x, sub, fs[:, j]) * spectral.phasor(nus[:, j], sub.n_chirps)
                                     * sub.rho).sum(axis=1)) / (x.shape[-1] * np.maximum(sub.count, 1))
                             for j in range(k)], axis=1)
        f[rows, :k], nu[rows, :k], amp[rows, :k] = fs, nus, amps
    return _estimates(f, nu, amp, present & valid[:, None], scale, chirps, geometry, method, couple)


def _refine_walking(frames, rho, geometry: Geometry, f0, nu0, max_speed_mps: float, couple: bool,
                    lsb: float | None) -> Estimates:
    frames, rho = _check_inputs(frames, rho, geometry, "ml", lsb)
    f0, nu0 = np.asarray(f0, dtype=float), np.asarray(nu0, dtype=float)
    present = np.isfinite(f0) & np.isfinite(nu0)
    chirps = _Chirps.of(rho)
    x, scale, valid = _normalise(frames, chirps, lsb)
    f, v, amp = (np.full(f0.shape, np.nan) for _ in range(3))
    for j in range(f0.shape[1]):
        rows = np.flatnonzero(present[:, j] & valid)
        if rows.size:
            f[rows, j], v[rows, j], amp[rows, j] = refine_walking(
                x[rows], chirps.index[rows], chirps.mask[rows], chirps.n_chirps, f0[rows, j], nu0[rows, j], geometry,
                max_speed_mps)
    found = present & valid[:, None]
    velocity = np.where(chirps.count[:, None] < 2, np.nan, v)
    beat_hz = (f % 1.0) * geometry.fs_hz
    range_m = geometry.range_from_beat(beat_hz, np.nan_to_num(velocity) if couple else 0.0)
    nan = np.nan
    return Estimates(range_m=np.where(found, range_m, nan), velocity_mps=np.where(found, velocity, nan),
                     beat_hz=np.where(found, beat_hz, nan),
                     amplitude=np.where(found, amp * (scale[:, None] * (1.0 if geometry.iq else 2.0)), nan),
                     n_found=found.sum(axis=1).astype(np.int64), method="ml_walking")


def _start_pad(method: str) -> int:
    """Zero padding of _start's Doppler FFT: 2 for a start that Newton steps refine, 8 for a final answer."""
    return 2 if method == "ml" else 8


def _interpolate(x, chirps: _Chirps, f, nu, iq, pad: int):
    """From cells to sub-bin frequencies, as `_one_target` does for one (`_start` on the cells of f, nu)."""
    n_samp, md = x.shape[-1], chirps.n_chirps
    spec = scipy.fft.fft(x, axis=-1) if iq else scipy.fft.rfft(x, axis=-1)
    k0 = np.clip(np.rint(f * n_samp).astype(np.int64) % n_samp, 0, spec.shape[-1] - 1)
    l0 = np.rint(nu * md).astype(np.int64) % md
    f_out, nu_out, _ = _start(spec, chirps, k0, l0, n_samp, pad)
    return f_out, nu_out


def _refine(x, chirps: _Chirps, f, nu, amp, method, n_newton, music_length, iq):
    """ML refinement (ml: joint for one target, alternating for several) or MUSIC beat + ML Doppler (music,
    root_music) on the compacted x (C, A, N).

    The other targets, and for real samples the negative-frequency image of every target (x real =
    sum_k a_k e^{+j..} + conj(a_k) e^{-j..}), are removed in the reduced domain: their contributions to the
    per-chirp DTFT z[m] and to the Doppler-compensated sum y[n] are closed forms (RELAX-style cancellation).
    """
    n_cycles, n_samp = x.shape[0], x.shape[-1]
    n_chirps = chirps.n_chirps
    n_tgt = f.shape[1]
    if n_tgt == 1 and method == "ml":
        # one target: joint Newton steps on the 2-D periodogram, one pass over the samples each (joint.py)
        f1, nu1, a1 = joint.refine_tone(x, chirps.index, chirps.mask, n_chirps, f[:, 0], nu[:, 0], iq=iq,
                                        n_iter=n_newton)
        return f1[:, None], nu1[:, None], a1[:, None]
    rho = chirps.rho
    m_times = np.arange(n_chirps, dtype=float)
    n_times = np.arange(n_samp, dtype=float)
    rhof = rho.astype(float)
    f, nu = f.copy(), nu.copy()
    n_act = np.maximum(chirps.count, 1)
    length = music_length or int(min(n_samp // 4, 32))
    n_model = (1 if iq else 2) * n_tgt
    cancel = n_tgt > 1 or not iq

    def dirichlet(g, times, weights=None):  # sum_t w_t exp(j 2 pi g t), g (C,), t = 0..len-1
        e = spectral.phasor(g, times.size, +1.0)
        return (e if weights is None else e * weights).sum(axis=1)

    def amplitude(z, k):
        mt = spectral.phasor(nu[:, k], n_chirps) * rho
        return (z * mt).sum(axis=1) / (n_samp * n_act)

    def interference_z(k):  # (C, M) contribution of the others / images to z_k
        out = np.zeros((n_cycles, n_chirps), dtype=complex)
        for j in range(n_tgt):
            if j != k:
                out += (alpha[:, j] * dirichlet(f[:, j] - f[:, k], n_times))[:, None] * \
                    spectral.phasor(nu[:, j], n_chirps, +1.0) * rhof
            if not iq:
                out += (np.conj(alpha[:, j]) * dirichlet(-f[:, j] - f[:, k], n_times))[:, None] * \
                    spectral.phasor(nu[:, j], n_chirps) * rhof
        return out

    def interference_y(k):  # (C, N) contribution of the others / images to y_k
        out = np.zeros((n_cycles, n_samp), dtype=complex)
        for j in range(n_tgt):
            if j != k:
                out += (alpha[:, j] * dirichlet(nu[:, j] - nu[:, k], m_times, rhof))[:, None] * \
                    spectral.phasor(f[:, j], n_samp, +1.0)
            if not iq:
                out += (np.conj(alpha[:, j]) * dirichlet(-nu[:, j] - nu[:, k], m_times, rhof))[:, None] * \
                    spectral.phasor(f[:, j], n_samp)
        return out

    alpha = np.zeros(f.shape, dtype=complex)
    if n_tgt == 1:
        # one target: integrate at the column Doppler (error ~0.01 bin: negligible loss), refine the beat,
        # demodulate at it and refine the Doppler; the amplitude for the image of real samples comes from
        # the integrated vector itself. Two passes over the data.
        y = _integrate_fast(x, chirps, nu[:, 0])
        if not iq:
            c = np.pi * f[:, 0] * (n_samp - 1)  # move the centred DTFT's time origin to sample 0
            alpha[:, 0] = spectral.dtft_derivatives(y, f[:, 0], order=0)[0] * (np.cos(c) - 1j * np.sin(c)) / (
                n_samp * n_act)
            y = y - interference_y(0)
        if method == "ml":
            f[:, 0] = spectral.newton_refine(y, f[:, 0], n_iter=n_newton)
        else:
            f[:, 0] = _music_beat(y, f[:, 0], n_model, length, method == "root_music", n_samp)
        z = _demod_slow(x, chirps, f[:, 0])
        if not iq:
            alpha[:, 0] = amplitude(z, 0)
            z = z - interference_z(0)
        nu[:, 0] = spectral.newton_refine(z, nu[:, 0], n_iter=n_newton, times=m_times)
        alpha[:, 0] = amplitude(z, 0)
        return f, nu, np.abs(alpha)
    z_at = [_demod_slow(x, chirps, f[:, k]) for k in range(n_tgt)]  # per-chirp DTFT at the current beat
    for k in range(n_tgt):
        alpha[:, k] = amplitude(z_at[k], k)
    for _ in range(2 if n_tgt > 1 else 1):
        for k in range(n_tgt):
            z = z_at[k] - interference_z(k) if cancel else z_at[k]
            nu[:, k] = spectral.newton_refine(z, nu[:, k], n_iter=n_newton, times=m_times)
            alpha[:, k] = amplitude(z, k)
            y = _integrate_fast(x, chirps, nu[:, k])
            if cancel:
                y = y - interference_y(k)
            if method == "ml":
                f[:, k] = spectral.newton_refine(y, f[:, k], n_iter=n_newton)
            else:
                f[:, k] = _music_beat(y, f[:, k], n_model, length, method == "root_music", n_samp)
            z_at[k] = _demod_slow(x, chirps, f[:, k])
    for k in range(n_tgt):  # final Doppler at the final beats
        z = z_at[k] - interference_z(k) if cancel else z_at[k]
        nu[:, k] = spectral.newton_refine(z, nu[:, k], n_iter=n_newton, times=m_times)
        alpha[:, k] = amplitude(z, k)
    return f, nu, np.abs(alpha)
