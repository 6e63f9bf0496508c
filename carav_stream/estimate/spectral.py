"""Frequency kernels for one tone (or a few) in a uniformly sampled complex vector, vectorised over leading axes.

All frequencies are in cycles/sample (normalised, in [-0.5, 0.5) or [0, 1)); bins are in DFT-bin units.

    periodogram    P(f) = |Y(f)|^2,  Y(f) = sum_n y[n] exp(-j 2 pi f (n - n_c)),  n_c = (N-1)/2
    Candan (2013)  delta = tan(pi/N)/(pi/N) * Re[(X[k-1] - X[k+1]) / (2 X[k] - X[k-1] - X[k+1])]
    Newton (ML)    f <- f - P'(f) / P''(f), a few steps from the interpolated peak (safeguarded)
    MUSIC          forward-backward smoothed covariance (subvector length L), noise subspace E_n,
                   pseudo-spectrum 1 / ||E_n^H a(f)||^2, root-MUSIC from the polynomial a(1/z)^T E_n E_n^H a(z)
    MDL / AIC      Wax & Kailath (1985) information criteria on covariance eigenvalues
"""
from __future__ import annotations

import functools

import numpy as np
import scipy.fft

_TINY = 1e-300


def candan_delta(x_m1, x_0, x_p1, n_samples: int):
    """Sub-bin offset [bins] of a tone from three complex DFT values around the peak (Candan's
    bias-corrected Jacobsen estimator); x_* complex arrays of equal shape; n_samples = DFT length N
    of the unpadded signal. Result clipped to [-0.5, 0.5]; 0 where the denominator vanishes."""
    den = 2.0 * x_0 - x_m1 - x_p1
    ratio = np.divide(x_m1 - x_p1, den, out=np.zeros(np.shape(den), dtype=complex), where=np.abs(den) > _TINY)
    corr = np.tan(np.pi / n_samples) / (np.pi / n_samples)
    return _clip_half(corr * ratio.real)


def parabolic_delta(p_m1, p_0, p_p1):
    """Vertex offset [bins] of the parabola through three real samples; clipped to [-0.5, 0.5]."""
    den = p_m1 - 2.0 * p_0 + p_p1
    delta = np.divide(0.5 * (p_m1 - p_p1), den, out=np.zeros(np.shape(den)), where=np.abs(den) > _TINY)
    return _clip_half(delta)


def _clip_half(x):
    """x clipped to [-0.5, 0.5] (ufuncs: np.clip's dispatch costs several times more on the few values here)."""
    return np.minimum(np.maximum(x, -0.5), 0.5)


def phasor(f, n_len: int, sign: float = -1.0, origin: float = 0.0):
    """exp(sign * j 2 pi f (n - origin)) for n = 0..n_len-1, complex128 (..., n_len).

    Built as the outer product of two cos/sin tables of about sqrt(n_len) entries each (n = b B + i:
    w^(b B - origin) w^i): numpy's complex exp is slower, and so is the serial cumulative product w^n at
    n_len ~ 1000 and batches of 16+ (it is slightly faster for short vectors). Phase error
    ~ n_len * 1e-16 rad, far below any estimator's resolution.
    """
    f = np.asarray(f, dtype=float)
    block, t = _phasor_times(n_len, float(origin))
    n_blocks = t.size - block
    a = (sign * 2.0 * np.pi) * f[..., None] * t
    e = np.cos(a) + 1j * np.sin(a)
    out = e[..., block:, None] * e[..., None, :block]
    return out.reshape(f.shape + (n_blocks * block,))[..., :n_len]


@functools.lru_cache(maxsize=64)
def _phasor_times(n_len: int, origin: float):
    """phasor's block length B and read-only time table: i = 0..B-1, then b B - origin."""
    block = max(int(np.ceil(np.sqrt(n_len))), 1)
    n_blocks = -(-n_len // block)
    t = np.concatenate((np.arange(block), np.arange(0, n_blocks * block, block) - origin))  # i, then b B
    t.flags.writeable = False
    return block, t


def dtft_derivatives(y, f, times=None, order: int = 2):
    """Y, dY/df, d2Y/df2 of the DTFT of y at frequency f [cycles/sample], time origin at the centre.

    y      complex (..., N); f float (...); times (N,) sample times (default 0..N-1), centred internally
    order  highest derivative wanted (0: Y alone, 1: Y and dY/df)
    Returns order + 1 complex arrays of shape (...).
    """
    f = np.asarray(f, dtype=float)
    n_len = y.shape[-1]
    if times is None or (np.asarray(times).shape == (n_len,) and np.all(np.diff(times) == 1.0)):
        n = np.arange(n_len, dtype=float) - 0.5 * (n_len - 1)
        e = phasor(f, n_len, origin=0.5 * (n_len - 1))
    else:
        n = np.asarray(times, dtype=float)
        n = n - n.mean()
        ph = -2.0 * np.pi * f[..., None] * n
        e = np.cos(ph) + 1j * np.sin(ph)
    # sums along the last axis, no BLAS product: a cycle's result must not depend on the batch it came in (a
    # matrix product's rounding does, and the graph must equal the in-process chain bit for bit), and a threaded
    # zgemm stalls on a busy machine
    ye = y * e
    if order == 0:
        return (ye.sum(axis=-1),)
    w = -2j * np.pi * n
    yw = ye * w
    return (ye.sum(axis=-1), yw.sum(axis=-1), (yw * w).sum(axis=-1))[:order + 1]


def newton_refine(y, f0, *, n_iter: int = 1, max_step: float | None = None, times=None):
    """Maximise the periodogram |Y(f)|^2 of y (..., N) from f0 (...) by safeguarded Newton steps.

    max_step  largest step [cycles/sample], default 0.5 / N (half a bin)
    A step is taken only where the periodogram is locally concave; otherwise the step is a clipped gradient
    step of max_step / 4. The result never has a lower periodogram than f0.
    Returns f (...) float [cycles/sample].
    """
    y = np.asarray(y)
    n_samples = y.shape[-1]
    max_step = 0.5 / n_samples if max_step is None else max_step
    f0 = np.asarray(f0, dtype=float)
    f = f0.copy()
    p_start = None
    for _ in range(n_iter):
        y0, y1, y2 = dtft_derivatives(y, f, times)
        if p_start is None:
            p_start = np.abs(y0) ** 2
        d1 = 2.0 * np.real(np.conj(y0) * y1)
        d2 = 2.0 * (np.abs(y1) ** 2 + np.real(np.conj(y0) * y2))
        concave = d2 < 0
        step = np.where(concave, -d1 / np.where(concave, d2, -1.0), np.sign(d1) * max_step / 4.0)
        f = f + np.clip(step, -max_step, max_step)
    if p_start is None:
        return f
    (y0,) = dtft_derivatives(y, f, times, order=0)
    worse = np.abs(y0) ** 2 < p_start
    return np.where(worse, f0, f)


def fb_covariance(y, length: int):
    """Forward-backward smoothed covariance (..., L, L) of the subvectors y[i:i+L] of y (..., N)."""
    h = np.lib.stride_tricks.sliding_window_view(y, length, axis=-1)  # (..., S, L)
    r = np.einsum("...si,...sj->...ij", h, h.conj()) / h.shape[-2]
    rb = np.flip(r, axis=(-2, -1)).conj()
    return 0.5 * (r + rb)


def subspaces(cov, n_signal: int):
    """Eigenvalues (ascending, (..., L)) and the signal eigenvectors (..., L, n_signal) of Hermitian cov."""
    w, v = np.linalg.eigh(cov)
    return w, v[..., :, cov.shape[-1] - n_signal:]


def music_pseudospectrum(sig_vecs, nfft: int):
    """MUSIC pseudo-spectrum on the nfft-point grid f = k / nfft from the signal eigenvectors (..., L, K).

    Uses ||E_n^H a||^2 = L - ||E_s^H a||^2 (orthonormal eigenvectors), so only K FFTs are needed.
    Returns float (..., nfft).
    """
    length = sig_vecs.shape[-2]
    proj = np.abs(scipy.fft.fft(sig_vecs, n=nfft, axis=-2)) ** 2  # |e^H a(f)|^2, a(f) = exp(+j 2 pi f l)
    den = length - proj.sum(axis=-1)
    return 1.0 / np.maximum(den, length * 1e-15)


def root_music_roots(sig_vecs, n_signal: int):
    """Root-MUSIC frequencies [cycles/sample] (..., n_signal): the n_signal roots inside the unit circle
    closest to it of sum_d c_d z^d, c_d = sum of diagonal d of C = I - E_s E_s^H (the noise projector).

    sig_vecs  (..., L, K) orthonormal signal eigenvectors, L > n_signal
    Also returns the root magnitudes (..., n_signal).
    """
    length = sig_vecs.shape[-2]
    c = np.eye(length) - sig_vecs @ np.swapaxes(sig_vecs.conj(), -1, -2)
    # D(z) = a(1/z)^T C a(z) = sum_d z^d sum_{j - i = d} C[i, j];  coefficients highest power first
    offsets = np.arange(length - 1, -length, -1)
    coeffs = np.stack([np.trace(c, offset=int(d), axis1=-2, axis2=-1) for d in offsets], axis=-1)
    lead = coeffs[..., :1]
    lead = np.where(np.abs(lead) > _TINY, lead, _TINY)
    monic = coeffs / lead
    deg = monic.shape[-1] - 1
    batch = monic.shape[:-1]
    comp = np.zeros(batch + (deg, deg), dtype=complex)
    comp[..., 0, :] = -monic[..., 1:]
    comp[..., np.arange(1, deg), np.arange(deg - 1)] = 1.0
    roots = np.linalg.eigvals(comp)  # (..., deg)
    mag = np.abs(roots)
    # roots come in pairs z, 1/z*: keep the inside ones, rank by distance to the unit circle
    dist = np.where(mag <= 1.0 + 1e-12, 1.0 - mag, np.inf)
    order = np.argsort(dist, axis=-1)[..., :n_signal]
    chosen = np.take_along_axis(roots, order, axis=-1)
    return np.angle(chosen) / (2.0 * np.pi), np.abs(chosen)


def information_criterion_order(eigvals, n_snapshots, *, criterion: str = "mdl", max_order: int | None = None,
                                floor: float = 1e-10):
    """Number of signals from covariance eigenvalues (..., L) by MDL or AIC (Wax & Kailath 1985).

    n_snapshots  effective number of independent snapshots (scalar or (...))
    Eigenvalues are clamped to floor (default 1e-10) times the largest: below that lies float32 rounding, so
    noise-free (rank-deficient) covariances give their rank.
    Returns int array (...).
    """
    if criterion not in ("mdl", "aic"):
        raise ValueError(f"information_criterion_order: criterion must be 'mdl' or 'aic', got {criterion!r}")
    lam = np.sort(np.asarray(eigvals, dtype=float), axis=-1)[..., ::-1]
    lam = np.maximum(lam, floor * np.maximum(lam[..., :1], _TINY))
    length = lam.shape[-1]
    max_order = length - 1 if max_order is None else min(max_order, length - 1)
    s = np.asarray(n_snapshots, dtype=float)[..., None]
    ks = np.arange(max_order + 1)
    crit = []
    for k in ks:
        tail = lam[..., k:]
        p = length - k
        log_geo = np.mean(np.log(tail), axis=-1)
        log_ari = np.log(np.mean(tail, axis=-1))
        ll = s[..., 0] * p * (log_ari - log_geo)
        free = k * (2 * length - k)
        pen = 0.5 * free * np.log(s[..., 0]) if criterion == "mdl" else float(free)
        crit.append(ll + pen)
    return np.argmin(np.stack(crit, axis=-1), axis=-1)


def toeplitz_covariance_from_power(power_spectrum, length: int, n_samples: int):
    """Toeplitz covariance (..., L, L) from a power spectrum (..., nfft) (sum over snapshots of |FFT|^2 of
    n_samples-long records, nfft >= 2 n_samples so the autocorrelation is not circular):
    R[i, j] = r[i - j] with the unbiased lag estimate r[l] = IFFT(power)[l] / (n_samples - l), normalised to
    r[0] = 1. Unbiased lags keep a noise-free sum of K tones exactly rank K."""
    r = scipy.fft.ifft(power_spectrum, axis=-1)[..., :length] / (n_samples - np.arange(length))
    r = r / np.maximum(np.abs(r[..., :1]), _TINY)
    idx = np.arange(length)
    lag = idx[:, None] - idx[None, :]
    cov = np.where(lag >= 0, r[..., np.abs(lag)], np.conj(r[..., np.abs(lag)]))
    return cov


__all__ = ["candan_delta", "parabolic_delta", "dtft_derivatives", "newton_refine", "fb_covariance",
           "subspaces", "music_pseudospectrum", "root_music_roots", "information_criterion_order",
           "toeplitz_covariance_from_power"]
