"""Target estimation of Algorithm 1, step 6: range and radial velocity from the active chirps of clean cycles.

Pipeline, vectorised over cycles (C cycles, M chirps, N fast-time samples):

1. Silent chirps are zeroed (rho False): every sum below runs over the active chirps only, and the
   slow-time spectrum of the zero-filled chirps is exactly the non-uniform DFT of the sparse active set.
2. Range-Doppler map |FFT_slow(FFT_fast(x))|^2 (fast-time FFT length nr, slow-time length md); targets are the
   K largest local maxima (K given, or estimated by MDL/AIC on a Toeplitz covariance built from the
   non-coherently integrated power spectrum of the active chirps).
3. Refinement by method:
     fft_peak      grid peak (bin centres)
     fft_zeropad   zero-padded grid (zeropad x in range, 4x in Doppler) + parabolic interpolation of |D|
     fft_interp    Candan's bias-corrected three-bin interpolation in range, parabolic in Doppler
     ml            fft_interp, then alternating safeguarded Newton steps on the 2-D periodogram
                   |sum_{m active} sum_n x[m,n] exp(-j 2 pi (f n + nu m))|^2: Doppler-compensated coherent
                   integration over the active chirps for the beat f, and the non-uniform slow-time periodogram
                   (sparse chirp times) for nu; several targets by RELAX-style cancellation of the others
     music         Doppler-compensated coherent integration over the active chirps, forward-backward smoothed
                   covariance (subvector length L), MUSIC pseudo-spectrum on a fine grid around the FFT peak
     root_music    as music, frequency from the roots of the root-MUSIC polynomial (model order doubles for
                   real I-only samples)
   Doppler for ml / music / root_music: Newton on the non-uniform slow-time periodogram at the refined beat.
4. Range with range-Doppler coupling removed: R = c/(2S) (f_b - 2 v / lambda)   (see geometry.py)

Inputs are scaled per cycle by their largest magnitude first, so amplitudes of 1e-30 and noise-free frames
(rank-deficient covariances) are handled; cycles without active chirps, with non-finite samples or with no
energy give NaN.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.geometry import Geometry

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


def _check_inputs(frames, rho, geometry: Geometry, method: str):
    if method not in METHODS:
        raise ValueError(f"estimate: method must be one of {METHODS}, got {method!r}")
    if not isinstance(geometry, Geometry):
        raise TypeError(f"estimate: geometry must be a Geometry, got {type(geometry).__name__}")
    frames = np.asarray(frames)
    if frames.ndim != 3:
        raise ValueError(f"estimate: frames must be (n_cycles, n_chirps, n_samples), got shape {frames.shape}")
    if frames.shape[-1] != geometry.n_samples:
        raise ValueError(f"estimate: frames have {frames.shape[-1]} samples per chirp, geometry.n_samples is "
                         f"{geometry.n_samples}")
    if np.iscomplexobj(frames) != geometry.iq:
        kind = "complex" if np.iscomplexobj(frames) else "real"
        raise ValueError(f"estimate: frames are {kind} ({frames.dtype}) but geometry.iq is {geometry.iq}")
    rho = np.asarray(rho)
    if rho.dtype != bool:
        raise TypeError(f"estimate: rho must be bool (n_cycles, n_chirps), got dtype {rho.dtype}")
    if rho.shape != frames.shape[:2]:
        raise ValueError(f"estimate: rho has shape {rho.shape}, expected frames.shape[:2] = {frames.shape[:2]}")
    return frames, rho


def _normalise(frames, rho):
    """Zero silent chirps, drop non-finite cycles, scale each cycle to unit peak |I| or |Q|.

    Returns x (complex64 or float32, same shape), scale (C,) float64 and valid (C,) bool."""
    work_dtype = np.complex64 if np.iscomplexobj(frames) else np.float32
    x = frames.astype(work_dtype, copy=False) * rho[..., None]
    flat = x.view(np.float32).reshape(x.shape[0], -1)
    peak = np.max(np.abs(flat), axis=1).astype(float)  # NaN/inf propagate here
    valid = np.isfinite(peak) & (peak > 0) & rho.any(axis=1)
    scale = np.where(valid, peak, 1.0)
    x *= (1.0 / scale).astype(np.float32)[:, None, None]
    x[~valid] = 0
    return x, scale, valid


def _estimate_order(x, rho, criterion: str, max_targets: int, iq: bool):
    """Model order per cycle from MDL/AIC on the Toeplitz covariance of the active chirps' summed power."""
    n = x.shape[-1]
    length = int(min(max(4 * max_targets + 4, 16), n // 2))
    nfft = scipy.fft.next_fast_len(2 * n)
    spec = scipy.fft.fft(x.astype(np.complex128), n=nfft, axis=-1)
    power = (np.abs(spec) ** 2).sum(axis=1)
    cov = spectral.toeplitz_covariance_from_power(power, length, n)
    eig = np.linalg.eigvalsh(cov)
    n_act = rho.sum(axis=1)
    snaps = np.maximum(n_act * (n // length), 1)
    per = 1 if iq else 2
    order = spectral.information_criterion_order(eig, snaps, criterion=criterion, max_order=per * max_targets)
    return np.minimum((order + per - 1) // per, max_targets)


def _doppler_column(spec, cyc, k0, l0, md, n_tgt, pad: int = 8):
    """Slow-time frequency [cycles/chirp] (C, K) from a pad-times zero-padded Doppler FFT of the range bins
    k0 (C, K) of spec (C, M, nb), with a parabolic vertex. One target: the global maximum of the column
    (robust to the high sidelobes of the sparse active set when the coarse grid scallops); several: the
    maximum within one coarse bin of the 2-D peak l0."""
    col = spec[cyc, :, k0]  # (C, K, M)
    n_pad = md * pad
    pw = np.abs(scipy.fft.fft(col, n=n_pad, axis=-1)).astype(float)
    if n_tgt == 1:
        j = np.argmax(pw, axis=-1)
    else:
        win = (np.arange(-pad, pad + 1)[None, None, :] + (l0 * pad)[..., None]) % n_pad
        j = np.take_along_axis(win, np.argmax(np.take_along_axis(pw, win, axis=-1), axis=-1)[..., None],
                               axis=-1)[..., 0]
    p = [np.take_along_axis(pw, ((j + d) % n_pad)[..., None], axis=-1)[..., 0] for d in (-1, 0, 1)]
    return (j + spectral.parabolic_delta(*p)) / n_pad


def _integrate_fast(x, rho, nu):
    """Doppler-compensated coherent sum over active chirps: y[c, n] = sum_m x[c,m,n] exp(-j 2 pi nu_c m).

    x complex64 or float32 (C, M, N), single-precision products (the data's precision); returns complex128."""
    e = spectral.phasor(nu, x.shape[1]) * rho
    if np.iscomplexobj(x):
        return np.matmul(e.astype(np.complex64)[:, None, :], x)[:, 0, :].astype(np.complex128)
    c = e.real.astype(np.float32)[:, None, :]
    s = e.imag.astype(np.float32)[:, None, :]
    return np.matmul(c, x)[:, 0, :] + 1j * np.matmul(s, x)[:, 0, :].astype(np.float64)


def _demod_slow(x, f):
    """Per-chirp DTFT at beat f [cycles/sample]: z[c, m] = sum_n x[c,m,n] exp(-j 2 pi f_c n), complex128."""
    e = spectral.phasor(f, x.shape[-1])
    if np.iscomplexobj(x):
        return np.matmul(x, e.astype(np.complex64)[:, :, None])[:, :, 0].astype(np.complex128)
    c = e.real.astype(np.float32)[:, :, None]
    s = e.imag.astype(np.float32)[:, :, None]
    return np.matmul(x, c)[:, :, 0] + 1j * np.matmul(x, s)[:, :, 0].astype(np.float64)


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


def _one_target(x, rho, method, zeropad, n_newton, music_length, iq):
    """Strongest target of every cycle: (f, nu, amp) each (C, 1); f [cycles/sample], nu [cycles/chirp],
    amp the positive-frequency tone amplitude per sample (normalised units)."""
    n_cycles, n_chirps, n_samp = x.shape
    nr = n_samp * (zeropad if method == "fft_zeropad" else 1)
    md = n_chirps * (4 if method == "fft_zeropad" else 1)
    spec = scipy.fft.fft(x, n=nr, axis=-1) if iq else scipy.fft.rfft(x, n=nr, axis=-1)
    rd = scipy.fft.fft(spec, n=md, axis=1)  # range-Doppler map over the active chirps (silent ones are zero)
    power = rd.real ** 2 + rd.imag ** 2
    if not iq:  # real samples: search strictly positive beats away from DC and Nyquist
        power[:, :, :1] = 0.0
        power[:, :, -1:] = 0.0
    idx = np.argmax(power.reshape(n_cycles, -1), axis=1)[:, None]
    l0, k0 = np.divmod(idx, power.shape[2])  # (C, 1) Doppler and range bins
    f = k0 / nr
    nu = l0 / md
    cyc = np.arange(n_cycles)[:, None]
    nb = power.shape[2]
    if method in ("fft_zeropad", "fft_interp", "ml", "music", "root_music"):
        def mag(l, k):
            return np.sqrt(power[cyc, l, k].astype(float))

        km, kp = np.clip(k0 - 1, 0, nb - 1), np.clip(k0 + 1, 0, nb - 1)
        if method == "fft_zeropad":
            f = f + spectral.parabolic_delta(mag(l0, km), mag(l0, k0), mag(l0, kp)) / nr
            nu = nu + spectral.parabolic_delta(mag((l0 - 1) % md, k0), mag(l0, k0), mag((l0 + 1) % md, k0)) / md
        else:
            f = f + spectral.candan_delta(rd[cyc, l0, km], rd[cyc, l0, k0], rd[cyc, l0, kp], n_samp) / nr
            nu = _doppler_column(spec, cyc, k0, l0, md, 1)
    amp = np.abs(rd[cyc, l0, k0]) / (n_samp * np.maximum(rho.sum(axis=1), 1))[:, None]
    if method in ("ml", "music", "root_music"):
        f, nu, amp = _refine(x, rho, f, nu, amp, method, n_newton, music_length, iq)
    return f, nu, amp


def estimate(frames, rho, geometry: Geometry, *, method: str = DEFAULT_METHOD, n_targets: int | None = 1,
             max_targets: int = 4, criterion: str = "mdl", zeropad: int = 8, music_length: int | None = None,
             n_newton: int = 1, couple: bool = True) -> Estimates:
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
    Returns Estimates; raises ValueError/TypeError naming the bad argument.
    """
    frames, rho = _check_inputs(frames, rho, geometry, method)
    if n_targets is not None and (int(n_targets) != n_targets or n_targets < 1):
        raise ValueError(f"estimate: n_targets must be a positive integer or None, got {n_targets!r}")
    if int(zeropad) != zeropad or zeropad < 1:
        raise ValueError(f"estimate: zeropad must be a positive integer, got {zeropad!r}")
    n_cycles, n_chirps, n_samp = frames.shape
    iq = geometry.iq
    x, scale, valid = _normalise(frames, rho)

    if n_targets is None:
        order = np.where(valid, _estimate_order(x, rho, criterion, max_targets, iq), 0)
        width = max(int(order.max(initial=0)), 1)
    else:
        width = int(n_targets)
        order = np.where(valid, width, 0)

    if width == 1:
        f, nu, amp = _one_target(x, rho, method, zeropad, n_newton, music_length, iq)
    else:
        # RELAX-style sequential search: the strongest target first, removed from the data before the next
        # search (its range and Doppler sidelobes -- high for a sparse active set -- would otherwise win),
        # then joint refinement of all targets with the others cancelled
        f = np.zeros((n_cycles, width))
        nu = np.zeros((n_cycles, width))
        amp = np.zeros((n_cycles, width))
        resid = x.copy()
        n_act = np.maximum(rho.sum(axis=1), 1)
        for k in range(width):
            fk, nuk, _ = _one_target(resid, rho, method, zeropad, n_newton, music_length, iq)
            f[:, k], nu[:, k] = fk[:, 0], nuk[:, 0]
            slow = spectral.phasor(nu[:, k], n_chirps) * rho
            alpha = (_demod_slow(resid, f[:, k]) * slow).sum(axis=1) / (n_samp * n_act)  # e^{+j..} amplitude
            amp[:, k] = np.abs(alpha)
            tone = (alpha[:, None] * slow.conj())[:, :, None] * spectral.phasor(f[:, k], n_samp, +1.0)[:, None, :]
            resid = resid - (tone if iq else 2.0 * tone.real).astype(resid.dtype)  # real: a e^{..} + conj
        if method in ("ml", "music", "root_music"):
            f, nu, amp = _refine(x, rho, f, nu, amp, method, n_newton, music_length, iq)

    nu = (nu + 0.5) % 1.0 - 0.5
    beat_hz = (f % 1.0) * geometry.fs_hz
    velocity = geometry.velocity_from_slow_freq(nu)
    found = np.arange(width)[None, :] < order[:, None]
    one_chirp = rho.sum(axis=1) < 2
    velocity = np.where(one_chirp[:, None], np.nan, velocity)
    range_m = geometry.range_from_beat(beat_hz, np.nan_to_num(velocity) if couple else 0.0)
    nan = np.nan
    return Estimates(range_m=np.where(found, range_m, nan), velocity_mps=np.where(found, velocity, nan),
                     beat_hz=np.where(found, beat_hz, nan),
                     amplitude=np.where(found, amp * (scale[:, None] * (1.0 if iq else 2.0)), nan),
                     n_found=order.astype(np.int64), method=method)


def _refine(x, rho, f, nu, amp, method, n_newton, music_length, iq):
    """Alternating ML refinement (ml) or MUSIC beat + ML Doppler (music, root_music).

    The other targets, and for real samples the negative-frequency image of every target (x real =
    sum_k a_k e^{+j..} + conj(a_k) e^{-j..}), are removed in the reduced domain: their contributions to the
    per-chirp DTFT z[m] and to the Doppler-compensated sum y[n] are closed forms (RELAX-style cancellation).
    """
    n_cycles, n_chirps, n_samp = x.shape
    n_tgt = f.shape[1]
    xc = x
    m_times = np.arange(n_chirps, dtype=float)
    n_times = np.arange(n_samp, dtype=float)
    rhof = rho.astype(float)
    f, nu = f.copy(), nu.copy()
    n_act = np.maximum(rho.sum(axis=1), 1)
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
        y = _integrate_fast(xc, rho, nu[:, 0])
        if not iq:
            c = np.pi * f[:, 0] * (n_samp - 1)  # move the centred DTFT's time origin to sample 0
            alpha[:, 0] = spectral.dtft_derivatives(y, f[:, 0])[0] * (np.cos(c) - 1j * np.sin(c)) / (n_samp * n_act)
            y = y - interference_y(0)
        if method == "ml":
            f[:, 0] = spectral.newton_refine(y, f[:, 0], n_iter=n_newton)
        else:
            f[:, 0] = _music_beat(y, f[:, 0], n_model, length, method == "root_music", n_samp)
        z = _demod_slow(xc, f[:, 0])
        if not iq:
            alpha[:, 0] = amplitude(z, 0)
            z = z - interference_z(0)
        nu[:, 0] = spectral.newton_refine(z, nu[:, 0], n_iter=n_newton, times=m_times)
        alpha[:, 0] = amplitude(z, 0)
        return f, nu, np.abs(alpha)
    z_at = [_demod_slow(xc, f[:, k]) for k in range(n_tgt)]  # per-chirp DTFT at the current beat
    for k in range(n_tgt):
        alpha[:, k] = amplitude(z_at[k], k)
    for _ in range(2 if n_tgt > 1 else 1):
        for k in range(n_tgt):
            z = z_at[k] - interference_z(k) if cancel else z_at[k]
            nu[:, k] = spectral.newton_refine(z, nu[:, k], n_iter=n_newton, times=m_times)
            alpha[:, k] = amplitude(z, k)
            y = _integrate_fast(xc, rho, nu[:, k])
            if cancel:
                y = y - interference_y(k)
            if method == "ml":
                f[:, k] = spectral.newton_refine(y, f[:, k], n_iter=n_newton)
            else:
                f[:, k] = _music_beat(y, f[:, k], n_model, length, method == "root_music", n_samp)
            z_at[k] = _demod_slow(xc, f[:, k])
    for k in range(n_tgt):  # final Doppler at the final beats
        z = z_at[k] - interference_z(k) if cancel else z_at[k]
        nu[:, k] = spectral.newton_refine(z, nu[:, k], n_iter=n_newton, times=m_times)
        alpha[:, k] = amplitude(z, k)
    return f, nu, np.abs(alpha)
