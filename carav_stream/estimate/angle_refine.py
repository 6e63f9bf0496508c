"""One target per range-Doppler cell refined to its bounds: its beat, its Doppler and, from the virtual channels'
snapshots at them, its azimuth by maximum likelihood (a 1-D search).

Model (angle.py): x[r, k, n] = A exp(j 2 pi (f n + nu k)) exp(j 2 pi x_v s), s = sin(theta), v = j R + r for chirp
k = l S + j, plus white noise (the real part, and real noise, for I-only samples). From a cell (f0, nu0) (a CFAR
list's bins) and the coarse s0 of the cell's angle spectrum:

    beat      the coherent sum h[n] = sum_{r,k} rho_k conj(a_v(s)) exp(-j 2 pi nu k) x[r, k, n] over chirps and
              receivers, Candan's three-bin interpolation of its DFT around f0 (spectral.candan_delta). The beat
              is common to every channel: an error there costs SNR (a fraction (pi delta)^2 / 3 at delta bins), never
              angle.
    per chirp c[r, k] = the LS amplitude of the tone at f in chirp k of receiver r: sum_n x exp(-j 2 pi f n) / N for
              I/Q; for I-only x = (c e^{j w n} + conj(c) e^{-j w n}) / 2, w = 2 pi f, and with g that sum (times N),
              p = N and q = sum_n exp(2 j w n) the normal equations 2 g = c p + conj(c q) give
              c = 2 (g p - conj(g) conj(q)) / (p^2 - |q|^2): the image at -f removed exactly, which a plain
              DFT leaves at |q| / N <= 1 / (N |sin(2 pi f)|) of the tone, with a phase of its own on every channel
              (the image's azimuth is -theta): far above the noise of a snapshot summed over N L samples.
    Doppler   Newton steps (spectral.newton_refine) on the periodogram of y[k] = rho_k sum_r conj(a_v(s)) c[r, k]
              over the chirps, from the parabolic vertex of its 4x padded FFT within a bin of nu0: the transmitters'
              angle phases removed, a slot's Doppler phase is part of the chirp-to-chirp progression. An error here
              is a TDM phase error on the later slots, which biases the angle: it is refined first.
    snapshot  z_v = 1 / L_a sum_{l active} c[r, l S + j] exp(-j 2 pi nu (l S + j)): Doppler and TDM phase removed
              (tdm False: the slot's part j left in). Its noise variance from the loops' scatter about z_v,
              var z_v = sum_{v,l} |c' - z_v|^2 / (V L_a (L_a - 1)), c' the compensated loop values.
    azimuth   the ML of one tone over the positions: s maximising |sum_v z_v exp(-j 2 pi x_v s)|^2, Newton steps
              (spectral.newton_refine with the positions as sample times) from the parabolic vertex of the angle
              spectrum's peak (angle.angle_spectrum); its bound is angle_crlb.azimuth_crlb at
              SNR_eff = b^2 / var z_v, b = |a(s)^H z| / V.

The Doppler, snapshot and azimuth steps are repeated `n_iter` times (each uses the last azimuth); the beat once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

from carav_stream.estimate import spectral
from carav_stream.estimate.angle import angle_spectrum, check_frames, sin_grid
from carav_stream.estimate.virtual_array import VirtualArray

__all__ = ["Cells", "refine_cells", "chirp_amplitudes", "ml_sin", "coarse_sin"]

DOPPLER_PAD = 4      # the Doppler start's zero padding (a start within a bin for the Newton steps)
N_NEWTON = 2         # Newton steps of the Doppler and of the azimuth per iteration (from a start within a grid step)


@dataclass(frozen=True)
class Cells:
    """Refined cells, float64 (C, K) but snapshots; NaN where no cell was given.

    f           beat [cycles/sample], in [0, 1)
    nu          chirp-to-chirp Doppler progression [cycles/chirp], in [-1/(2S), 1/(2S))
    sin_theta   sin(azimuth)
    amplitude   |A|, input units
    snr_eff     b^2 / var z_v: the SNR per virtual channel of the snapshots (angle_crlb.azimuth_crlb's SNR_eff)
    snapshots   complex128 (C, K, V): z_v, Doppler and TDM phases removed
    """

    f: np.ndarray
    nu: np.ndarray
    sin_theta: np.ndarray
    amplitude: np.ndarray
    snr_eff: np.ndarray
    snapshots: np.ndarray


def _at_beats(x, e):
    """sum_n x[c, i, n] e[c, k, n] -> complex128 (C, K, I): x float32 | complex64 (C, I, N), e complex (C, K, N).

    Single-precision products (the data's precision), one real matrix product per cycle with x as its contiguous
    left operand: complex samples are read as interleaved (re, im) float32 pairs against the columns (Re e, -Im e)
    and (Im e, Re e) (numpy's complex64 product against a few columns is two orders of magnitude slower)."""
    n_tgt = e.shape[1]
    et = np.swapaxes(e, 1, 2)                                                        # (C, N, K)
    if np.iscomplexobj(x):
        cols = np.empty((x.shape[0], 2 * x.shape[2], 2 * n_tgt), dtype=np.float32)
        cols[:, 0::2, :n_tgt], cols[:, 1::2, :n_tgt] = et.real, -et.imag
        cols[:, 0::2, n_tgt:], cols[:, 1::2, n_tgt:] = et.imag, et.real
        out = np.matmul(x.view(np.float32), cols).astype(float)
    else:
        cols = np.concatenate([et.real, et.imag], axis=-1).astype(np.float32)
        out = np.matmul(x, cols).astype(float)
    return np.swapaxes(out[..., :n_tgt] + 1j * out[..., n_tgt:], 1, 2)


def _weighted(w, x):
    """sum_i w[c, k, i] x[c, i, n] -> complex128 (C, K, N): w complex (C, K, I), x float32 | complex64 (C, I, N);
    one real matrix product per cycle as in _at_beats."""
    n_tgt = w.shape[1]
    rows = np.concatenate([w.real, w.imag], axis=1).astype(np.float32)              # (C, 2K, I)
    if np.iscomplexobj(x):
        out = np.matmul(rows, x.view(np.float32)).astype(float)                      # (C, 2K, 2N) interleaved
        re, im = out[..., 0::2], out[..., 1::2]
        return (re[:, :n_tgt] - im[:, n_tgt:]) + 1j * (im[:, :n_tgt] + re[:, n_tgt:])
    out = np.matmul(rows, x).astype(float)
    return out[:, :n_tgt] + 1j * out[:, n_tgt:]


def chirp_amplitudes(x, f, *, iq: bool) -> np.ndarray:
    """c complex128 (C, K, R, M): each chirp's LS tone amplitude at the beats f (C, K) [cycles/sample] (module
    docstring; I-only: the image at -f removed). x float32 | complex64 (C, R, M, N)."""
    n_cycles, n_rx, n_chirps, n_samp = x.shape
    g = _at_beats(x.reshape(n_cycles, n_rx * n_chirps, n_samp), spectral.phasor(f, n_samp))
    g = g.reshape(f.shape + (n_rx, n_chirps))
    if iq:
        return g / n_samp
    w = 4.0 * np.pi * f                                              # q = sum_n exp(j w n), in closed form
    half = np.sin(0.5 * w)
    ratio = np.divide(np.sin(0.5 * n_samp * w), half, out=np.full(w.shape, float(n_samp)), where=np.abs(half) > 1e-12)
    q = (np.exp(0.5j * w * (n_samp - 1)) * ratio)[..., None, None]
    den = np.maximum(n_samp ** 2 - np.abs(q) ** 2, 1e-12 * n_samp ** 2)
    return 2.0 * (g * n_samp - np.conj(g) * np.conj(q)) / den


def _channel_weights(array: VirtualArray, sin_theta, n_chirps: int) -> np.ndarray:
    """conj(a_v(s)) for the channel of receiver r in chirp k, complex128 (C, K, R, M)."""
    a = array.steering(sin_theta).conj().reshape(sin_theta.shape + (array.n_slots, array.n_rx))
    slot = np.arange(n_chirps) % array.n_slots
    return np.swapaxes(a[..., slot, :], -1, -2)


def coarse_sin(z, array: VirtualArray, n_angle: int = 64) -> np.ndarray:
    """sin(theta) of the angle spectrum's peak of the snapshots z (..., V), at the parabolic vertex of its three
    grid values around it (spectral.parabolic_delta), float64 (...)."""
    p = angle_spectrum(z, array, n_angle)
    i = np.argmax(p, axis=-1)
    three = np.take_along_axis(p, np.clip(i[..., None] + np.arange(-1, 2), 0, n_angle - 1), axis=-1)
    delta = spectral.parabolic_delta(three[..., 0], three[..., 1], three[..., 2])
    return np.clip(sin_grid(n_angle)[i] + delta * 2.0 / n_angle, -1.0, 1.0)


def ml_sin(z, positions_wl, s0, n_newton: int = N_NEWTON) -> np.ndarray:
    """The ML sin(theta) of one tone over the positions: Newton steps on |sum_v z_v exp(-j 2 pi x_v s)|^2 from s0
    (...), z (..., V); float64 (...)."""
    x = np.asarray(positions_wl, dtype=float)
    span = max(float(x.max() - x.min()), 0.5)
    s = spectral.newton_refine(z, s0, n_iter=n_newton, max_step=0.5 / span, times=x)
    return np.clip(s, -1.0, 1.0)


def _beat(x, array, rho, f, nu, s):
    """Candan's beat [cycles/sample] (C, K) from the coherent sum over chirps and receivers at (nu, s)."""
    n_cycles, n_rx, n_chirps, n_samp = x.shape
    w = _channel_weights(array, s, n_chirps) * (spectral.phasor(nu, n_chirps) * rho[:, None, :])[..., None, :]
    h = _weighted(w.reshape(f.shape + (n_rx * n_chirps,)), x.reshape(n_cycles, n_rx * n_chirps, n_samp))
    three = (h[..., None, :] * spectral.phasor(f[..., None] + np.arange(-1, 2) / n_samp, n_samp)).sum(axis=-1)
    return (f + spectral.candan_delta(three[..., 0], three[..., 1], three[..., 2], n_samp) / n_samp) % 1.0


def _doppler(c, array, rho, nu0, s):
    """nu [cycles/chirp] (C, K): Newton on the periodogram of the chirps' beamformed amplitudes, from the padded
    FFT's vertex within a bin of nu0."""
    n_chirps = c.shape[-1]
    y = (c * _channel_weights(array, s, n_chirps)).sum(axis=-2) * rho[:, None, :]    # (C, K, M)
    n_pad = DOPPLER_PAD * n_chirps
    p = np.abs(scipy.fft.fft(y, n=n_pad, axis=-1)) ** 2
    win = (np.rint(nu0 * n_pad).astype(np.int64)[..., None] + np.arange(-DOPPLER_PAD, DOPPLER_PAD + 1)) % n_pad
    j = np.take_along_axis(win, np.argmax(np.take_along_axis(p, win, axis=-1), axis=-1)[..., None], axis=-1)[..., 0]
    three = np.take_along_axis(p, (j[..., None] + np.arange(-1, 2)) % n_pad, axis=-1)
    start = (j + spectral.parabolic_delta(three[..., 0], three[..., 1], three[..., 2])) / n_pad
    start = start - np.floor(start + 0.5)
    return spectral.newton_refine(y, start, n_iter=N_NEWTON)


def _snapshots(c, array, rho, nu, tdm: bool):
    """(z complex128 (C, K, V), var z_v (C, K)): the loops' compensated amplitudes averaged (module docstring)."""
    n_cycles, n_tgt, n_rx, n_chirps = c.shape
    s, n_loops = array.n_slots, n_chirps // array.n_slots
    k = np.arange(n_chirps) if tdm else np.repeat(np.arange(0, n_chirps, s), s)     # the slot's phase kept or not
    u = c * np.exp(-2j * np.pi * nu[..., None] * k)[..., None, :]
    u = u.reshape(n_cycles, n_tgt, n_rx, n_loops, s).transpose(0, 1, 4, 2, 3).reshape(n_cycles, n_tgt, s * n_rx,
                                                                                      n_loops)
    act = rho[:, ::s][:, None, None, :]                                            # loops: rho constant in a loop
    n_act = np.maximum(act.sum(axis=-1), 1)
    z = (u * act).sum(axis=-1) / n_act
    scatter = (np.abs(u - z[..., None]) ** 2 * act).sum(axis=(-1, -2))
    var = scatter / (array.n_virtual * n_act[..., 0] * np.maximum(n_act[..., 0] - 1, 1))
    return z, var


def refine_cells(frames, array: VirtualArray, f0, nu0, rho=None, *, n_iter: int = 2, tdm: bool = True,
                 n_angle: int = 64) -> Cells:
    """Every listed cell refined (module docstring). frames (C, R, M, N) float32 | complex64; f0, nu0 float (C, K):
    the cells' beats [cycles/sample] and Doppler progressions [cycles/chirp], NaN for none; rho bool (C, M) or
    None (all active). Returns Cells; NaN for the cells of a cycle without an active loop or with a non-finite
    sample."""
    x, rho = check_frames(frames, array, rho)
    f0, nu0 = np.asarray(f0, dtype=float), np.asarray(nu0, dtype=float)
    if f0.ndim != 2 or f0.shape != nu0.shape or f0.shape[0] != x.shape[0]:
        raise ValueError(f"refine_cells: f0 {f0.shape} and nu0 {nu0.shape} must be (n_cycles, K) for {x.shape[0]} "
                         "cycles")
    iq = np.iscomplexobj(x)
    usable = rho.any(axis=1) & np.isfinite(x).all(axis=(1, 2, 3))          # an active loop, finite samples
    listed = np.isfinite(f0) & np.isfinite(nu0) & usable[:, None]
    if not usable.all():
        x = np.where(usable[:, None, None, None], x, 0).astype(x.dtype, copy=False)
    f, nu = np.where(listed, f0 % 1.0, 0.0), np.where(listed, nu0, 0.0)
    act = rho.astype(float)
    z, _ = _snapshots(chirp_amplitudes(x, f, iq=iq), array, rho, nu, tdm)
    s = coarse_sin(z, array, n_angle)
    f = _beat(x, array, act, f, nu, s)
    c = chirp_amplitudes(x, f, iq=iq)
    for _ in range(n_iter):
        nu = _doppler(c, array, act, nu, s)
        z, var = _snapshots(c, array, rho, nu, tdm)
        s = ml_sin(z, array.positions_wl, s)
    b = np.abs((z * array.steering(s).conj()).sum(axis=-1)) / array.n_virtual
    wrap = 1.0 / array.n_slots
    nu = (nu + 0.5 * wrap) % wrap - 0.5 * wrap
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = b ** 2 / var

    def keep(a):
        return np.where(listed, a, np.nan)
    return Cells(keep(f), keep(nu), keep(s), keep(b), keep(snr), np.where(listed[..., None], z, np.nan))
