"""The energy of a chirp of quantised Gaussian noise, exactly: the law of D0 when the ADC's step is not small.

A mid-tread ADC of step lsb turns a noise component n ~ N(0, sigma_c^2) into the code c = rint(n / lsb) (clipping
aside: the noise stays far inside the full scale). With r = sigma_c / lsb,

    P(c = 0) = 1 - 2 Q(1 / (2 r)),    P(|c| = k) = 2 [Q((k - 1/2) / r) - Q((k + 1/2) / r)]   (k >= 1, Q = N(0,1) sf),

and a chirp's energy in codes S = sum_{i <= nu} c_i^2 (nu = N_s for I only, 2 N_s components for I/Q, each of
sigma_c = sigma_n or sigma_n / sqrt(2)) is a sum of nu i.i.d. integers, so D0 = lsb sqrt(S / N_s) / sigma_det >= eta
iff S >= s* = N_s eta^2 sigma_det^2 / lsb^2. For r well above 1 the quantisation error is nearly uniform and
independent of the noise (the Gaussian's characteristic function has fallen to exp(-2 pi^2 r^2) at the step's
frequency), and S / nu is close to a chi-square of variance sigma_c^2 + lsb^2 / 12: the law `carav_stream.firmware.
design` takes there. Below r = 1/2 most codes are 0 and that law fails: silent chirps quantise below the noise's RMS.

P(S >= s*) is computed exactly (up to rounding) by exponential tilting: with K(t) = log E[exp(t c^2)] and t >= 0
solving nu K'(t) = s* (t = 0 in the bulk), the tilted law of S, centred on s*, is the nu-fold convolution of the
tilted law of c^2 (FFT, on a grid long enough that nothing of it wraps onto s* and beyond), and

    P(S >= s*) = sum_{s >= s*} exp(nu K(t) - t s) P_t(S = s),

where only terms near s* count, so the rounding of the FFT, relative to the tilted law's peak there, is relative to
the result too: tails down to 1e-300 are resolved.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import scipy.fft
from scipy import optimize, special, stats

__all__ = ["code_log_pmf", "quantised_energy_logsf"]

TAIL_NATS = 60.0          # terms of the tilted laws more than e^-60 below their peak are left out


def code_log_pmf(r: float, n_codes: int) -> np.ndarray:
    """log P(c^2 = k^2) for k = 0 .. n_codes - 1, float64 (n_codes,); r = sigma_c / lsb > 0."""
    k = np.arange(n_codes, dtype=np.float64)
    lo, hi = stats.norm.logsf((k - 0.5) / r), stats.norm.logsf((k + 0.5) / r)
    with np.errstate(divide="ignore"):
        out = lo + np.log(-np.expm1(hi - lo))
    out[0] = math.log(-math.expm1(math.log(2.0) + float(stats.norm.logsf(0.5 / r))))
    out[1:] += math.log(2.0)
    return out


@lru_cache(maxsize=64)
def _table(r: float) -> tuple[np.ndarray, np.ndarray]:
    """(k^2, log P(c^2 = k^2)) for the codes up to where the law has fallen below e^-2000."""
    n = int(math.ceil(r * math.sqrt(4000.0))) + 2
    return np.arange(n, dtype=np.float64) ** 2, code_log_pmf(r, n)


def _codes(r: float, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(k^2, log P(c^2 = k^2) + t k^2) over the codes within TAIL_NATS of the tilted law's peak."""
    k2, lp = _table(r)
    lp = lp + t * k2
    keep = lp > lp.max() - TAIL_NATS
    return k2[keep], lp[keep]


def _cumulants(r: float, t: float) -> tuple[float, float, float]:
    """K(t), K'(t), K''(t) of c^2."""
    k2, lp = _codes(r, t)
    log_k = special.logsumexp(lp)
    w = np.exp(lp - log_k)
    mean = float(w @ k2)
    return float(log_k), mean, float(w @ (k2 - mean) ** 2)


def _tilt(s_star: float, nu: int, r: float) -> float | None:
    """t >= 0 with nu K'(t) = s* (0 when s* is at or below the mean), or None when s* lies beyond what the table's
    codes reach (every component beyond the law's last e^-2000)."""
    if nu * _cumulants(r, 0.0)[1] >= s_star:
        return 0.0
    t_max = 1.0 / (2.0 * r * r)                  # K(t) is finite below it: P(c^2 = k^2) ~ exp(-k^2 / (2 r^2))
    hi = t_max * (1 - 1e-12)
    if nu * _cumulants(r, hi)[1] < s_star:
        return None
    return float(optimize.brentq(lambda t: nu * _cumulants(r, t)[1] - s_star, 0.0, hi, xtol=1e-300, rtol=1e-10))


def _one(s_star: float, nu: int, r: float) -> float:
    if s_star <= 0:
        return 0.0
    s0 = math.ceil(s_star - 1e-9)
    t = _tilt(s0, nu, r)
    if t is None:
        # S >= s0 needs a component with c^2 >= s0 / nu, beyond the table, where P(c^2 = k^2) < e^-2000 and falls
        # faster than geometrically: P(S >= s0) <= nu e^-2000, returned as the bound (a probability of 0 in floats)
        return math.log(nu) - 2000.0
    log_k, mean, var = _cumulants(r, t)
    k2, lp = _codes(r, t)
    length = int(scipy.fft.next_fast_len(int(nu * mean + 80 * math.sqrt(nu * var) + k2.max()) + 2, real=True))
    y = np.zeros(length)
    inside = k2 < length
    np.add.at(y, k2[inside].astype(np.int64), np.exp(lp[inside] - log_k))
    f = scipy.fft.rfft(y)
    p = np.maximum(scipy.fft.irfft(f ** nu, length), 0.0)           # the tilted law of S (no wrap reaches s0)
    s = np.arange(s0, length)
    tail = p[s0:] * np.exp(-t * (s - s0))
    if not tail.any():
        return -math.inf
    return nu * log_k - t * s0 + math.log(float(tail.sum()))


def quantised_energy_logsf(s_star, nu: int, r: float) -> np.ndarray:
    """log P(S >= s*) for the code energy S of nu quantised noise components of r = sigma_c / lsb (any shape)."""
    s_star = np.asarray(s_star, dtype=np.float64)
    flat = s_star.ravel()
    uniq, inv = np.unique(flat, return_inverse=True)
    vals = np.array([_one(float(x), int(nu), float(r)) for x in uniq])
    return vals[inv].reshape(s_star.shape)
