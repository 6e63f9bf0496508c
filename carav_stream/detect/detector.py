"""CARAV cyberattack detector of Section V.A of the paper, as pure vectorised kernels (one module past 400 lines:
the kernels share the conventions stated here).

For one measurement cycle with received chirps R_k (k = 0..N_r-1, N_s samples each) and a balanced activation
sequence rho (exactly N_r/2 ones):

    ||s||_r   = sqrt(mean_m |s[m]|^2)                       (RMS; |.| is the modulus for I/Q samples)
    D0(k)     = ||R_k||_r / sigma_n
    Rbar_rho  = (1 / (N_r/2)) * sum_{rho(k)=1} ||R_k||_r
    D1(k)     = | ||R_k||_r - Rbar_rho | / (Rbar_rho + sigma_n)
    D(k)      = D0(k) if rho(k) = 0 else D1(k)
    Q         = max_k D(k),   C(eta) = Q / eta,   alarm  <=>  C(eta) >= 1

The detector sees a cycle only through its per-chirp RMS, so `detect` is `chirp_rms` followed by `detect_from_rms`.

A receiver array (`receivers=True`: frames (n_cycles, n_rx, n_chirps, n_samples)) gives one RMS per chirp over all
its receivers' samples, ||R_k||_r = sqrt(mean over (r, m) of |R_{k,r}[m]|^2): the RMS of the receivers' samples of
chirp k laid side by side, with every convention below unchanged (its law: carav_stream/detect/receivers.py).

A blind side of D1: an active chirp weaker than the mean gives D1 = (Rbar - ||R_k||_r) / (Rbar + sigma_n)
<= Rbar / (Rbar + sigma_n) < 1, so for eta >= 1 only an active chirp *above* the mean can raise an alarm. An attack
that adds the same power to every active chirp lifts Rbar with them and is invisible to D1 at any strength; only
D0, on the silent chirps, can see it (an attacker that knows rho, e.g. `lfsr_predictor` against an LFSR source,
is therefore invisible to C(eta) altogether; the secure activation source removes that knowledge).

Conventions for the degenerate cases (all documented, none emits a floating-point warning):

- x / 0 in D0 or D1 is +inf when x > 0 and 0 when x = 0. So sigma_n = 0 (a noise-free receiver) makes any energy in
  a silent chirp infinitely suspicious (D0 = inf, alarm) while an all-zero silent chirp gives D0 = 0; and
  Rbar_rho + sigma_n = 0 (all active chirps zero, sigma_n = 0) gives D1 = 0 on the active chirps.
- A chirp holding any NaN or Inf sample has RMS NaN. A cycle with such a chirp is `invalid`: its Q is +inf and it
  always raises the alarm ("invalid frame"); it never passes as clean.
- RMS is computed without overflow or underflow for every finite input (float32 inputs accumulate in float64;
  float64 chirps whose sum of squares leaves the safe float64 range are rescaled by their largest magnitude), so Q is
  invariant when the samples and sigma_n are scaled together.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Detection", "adc_chirp_rms", "chirp_rms", "chirp_rms_codes", "detect", "detect_from_rms",
           "estimate_sigma_n", "check_rho", "PAPER_ETA", "SUPPORTED_DTYPES"]

PAPER_ETA = 1.5     # the paper's threshold of C(eta) = Q / eta: the detector's default, the tables' reference

SUPPORTED_DTYPES = (np.dtype(np.float32), np.dtype(np.float64), np.dtype(np.complex64), np.dtype(np.complex128))

# A float64 sum of squares in [2**-900, finite) lost nothing to underflow (each underflowed square is < 2**-1022,
# i.e. a relative contribution below n * 2**-122) and did not overflow; outside it the chirp is recomputed scaled.
_SAFE_SUMSQ_MIN = 2.0 ** -900

# Integers below 2^24 are exact in float32: a float32 sum of code^2 below it is exact (chirp_rms_codes).
_EXACT_F32 = np.float32(2.0 ** 24)


@dataclass(frozen=True)
class Detection:
    """Verdict of the CARAV detector for a batch of cycles (or one cycle: the leading axis is then absent).

    rms      float64 (n_cycles, n_chirps)  per-chirp RMS ||R_k||_r, NaN for a chirp holding NaN/Inf
    d0, d1   float64 (n_cycles, n_chirps)  D0(k) and D1(k) on every chirp (diagnostics; D picks one per chirp)
    d        float64 (n_cycles, n_chirps)  combo detector D(k): D0 on silent chirps, D1 on active chirps
    rbar     float64 (n_cycles,)           Rbar_rho, mean RMS of the active chirps
    q        float64 (n_cycles,)           Q = max_k D(k); +inf for an invalid cycle
    c        float64 (n_cycles,)           C(eta) = Q / eta
    alarm    bool    (n_cycles,)           C(eta) >= 1, or invalid
    invalid  bool    (n_cycles,)           the cycle holds a NaN or Inf sample ("invalid frame" alarm)
    k_max    int64   (n_cycles,)           chirp index where Q is reached (-1 for an invalid cycle)
    by_d1    bool    (n_cycles,)           Q comes from an active chirp (D1) rather than a silent one (D0)
    eta      float                         threshold used
    """

    rms: np.ndarray
    d0: np.ndarray
    d1: np.ndarray
    d: np.ndarray
    rbar: np.ndarray
    q: np.ndarray
    c: np.ndarray
    alarm: np.ndarray
    invalid: np.ndarray
    k_max: np.ndarray
    by_d1: np.ndarray
    eta: float


def _check_frames(frames) -> np.ndarray:
    x = np.asarray(frames)
    if x.dtype not in SUPPORTED_DTYPES:
        names = ", ".join(str(d) for d in SUPPORTED_DTYPES)
        raise TypeError(f"frames: dtype {x.dtype} is not supported; expected one of {names} "
                        "(convert integer ADC codes to float first)")
    if x.ndim < 1 or x.shape[-1] == 0:
        raise ValueError(f"frames: need at least one sample per chirp on the last axis, got shape {x.shape}")
    return x


_BLOCK_SAMPLES = 1 << 16


def _sum_squares(xr: np.ndarray) -> np.ndarray:
    """Sum of squares over the last axis, accumulated in float64.

    float32 squares always fit float64 exactly enough (|x| <= 3.4e38 -> x^2 <= 1.2e77; subnormals become normal),
    so float32 input is upcast in cache-sized blocks of rows (faster than einsum's own casting buffers).
    """
    if xr.dtype == np.float64:
        return np.einsum("...i,...i->...", xr, xr)
    lead = xr.shape[:-1]
    rows = xr.reshape(-1, xr.shape[-1])
    out = np.empty(rows.shape[0], dtype=np.float64)
    step = max(1, _BLOCK_SAMPLES // max(1, rows.shape[1]))
    for i in range(0, rows.shape[0], step):
        b = rows[i: i + step].astype(np.float64)
        np.einsum("ij,ij->i", b, b, out=out[i: i + b.shape[0]])
    return out.reshape(lead)


def _side_by_side(x: np.ndarray, trailing: int = 1) -> np.ndarray:
    """(..., n_rx, n_chirps, n_samples[, 2]) -> (..., n_chirps, n_rx * n_samples[, 2]): each chirp's samples of
    every receiver in a row, receiver 0 first (a copy, unless n_rx = 1): one chirp, one sum, so the overflow and
    NaN conventions hold for the array's RMS as they do for one receiver's. `trailing`: axes after the chirps'."""
    if x.ndim < 2 + trailing:
        raise ValueError(f"frames: receivers=True needs a receiver axis before the chirps', shape (..., n_rx, "
                         f"n_chirps, n_samples{', 2' if trailing == 2 else ''}), got {x.shape}")
    ax = x.ndim - 2 - trailing                          # the receiver axis
    y = np.moveaxis(x, ax, ax + 1)                      # (..., n_chirps, n_rx, n_samples[, 2])
    return y.reshape(*y.shape[:ax + 1], y.shape[ax + 1] * y.shape[ax + 2], *y.shape[ax + 3:])


def chirp_rms(frames, *, receivers: bool = False) -> np.ndarray:
    """RMS of every chirp, sqrt(mean |s|^2) over the last (samples) axis, free of overflow and underflow.

    frames  float32 | float64 (I only) or complex64 | complex128 (I/Q), shape (..., n_samples)
    returns float64, shape (...); NaN where the chirp holds a NaN or Inf sample; 0 for an all-zero chirp.
    For I/Q, |s|^2 = I^2 + Q^2 and the mean is over the n_samples complex samples.
    receivers  frames (..., n_rx, n_chirps, n_samples): one RMS per chirp over all its receivers' samples, shape
               (..., n_chirps); NaN when any receiver's sample is NaN or Inf
    """
    x = _check_frames(frames)
    if receivers:
        x = _side_by_side(x)
    n_samples = x.shape[-1]
    if np.iscomplexobj(x):
        x = np.ascontiguousarray(x)
        xr = x.view(x.real.dtype).reshape(*x.shape[:-1], 2 * n_samples)
    else:
        xr = x
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        sumsq = np.asarray(_sum_squares(xr))
        redo = ~(sumsq >= _SAFE_SUMSQ_MIN) | ~np.isfinite(sumsq)
        rms = np.sqrt(sumsq / n_samples, out=np.empty_like(sumsq))
        if np.any(redo):
            rows = xr[redo].astype(np.float64, copy=False)
            scale = np.max(np.abs(rows), axis=-1)
            ok = np.isfinite(scale) & (scale > 0)
            out = np.where(np.isnan(scale) | np.isinf(scale), np.nan, 0.0)
            if np.any(ok):
                y = rows[ok] / scale[ok, None]
                out[ok] = scale[ok] * np.sqrt(np.einsum("...i,...i->...", y, y) / n_samples)
            rms[redo] = out
    return rms if rms.ndim else rms[()]


def chirp_rms_codes(codes, lsb: float, iq: bool = False, *, receivers: bool = False) -> np.ndarray:
    """RMS of every chirp, lsb * sqrt(mean code^2), from an ADC's integer codes: the sums are exact.

    codes  integer (..., n_samples) for I only, or (..., n_samples, 2) with I and Q for iq=True; every
           |code| <= 2^15 (any ADC up to 16 bits): squares summed in float64 are exact up to 2^23 samples
    lsb    the ADC's step in the unit of the result
    returns float64, shape (...) = the chirps; for I/Q, |s|^2 = I^2 + Q^2 averaged over the n_samples.
    receivers  codes (..., n_rx, n_chirps, n_samples[, 2]): one RMS per chirp over all its receivers' codes
               (exact up to 2^23 codes per chirp in all), shape (..., n_chirps)
    """
    c = np.asarray(codes)
    if not np.issubdtype(c.dtype, np.integer):
        raise TypeError(f"codes: expected an integer dtype, got {c.dtype}")
    if receivers:
        c = _side_by_side(c, 2 if iq else 1)
    lead = c.shape[:-2] if iq else c.shape[:-1]
    if iq and c.shape[-1:] != (2,):
        raise ValueError(f"codes: I/Q codes need a last axis of 2 (I, Q), got shape {c.shape}")
    n_samples = c.shape[-2] if iq else c.shape[-1]
    flat = c.reshape(-1, n_samples * (2 if iq else 1))
    n_rows = flat.shape[0]
    # Each chirp's sum of squares is a stacked (1 x n) @ (n x 1) product over chunks of 256 chirps (faster than
    # einsum here), first in float32: half the bytes of the float64 copy that exactness costs in numpy.
    # A float32 sum below 2^24 is exact and a float32 sum of a true sum S >= 2^24 is not below 2^24, whatever the
    # order, FMA or wider accumulator: every term code^2 and every partial sum is a non-negative integer, and each
    # computed partial sum is at least min(its exact value, 2^24) (rounding is monotonic and 2^24 representable),
    # exact when below it (integers below 2^24 are exact in float32). So a chirp whose float32 sum is below 2^24 is
    # done; the others (a single |code| >= 2^12 suffices; 2^24 itself is ambiguous: 2^24 + 1 rounds to it) are
    # gathered and redone in float64, where every partial sum is an integer below 2^53. Gathering costs more per
    # code than a plain float64 chunk, so once a chunk (the first one is 32 chirps: a probe) is more than a sixth
    # loud, that chunk and the rest of the frame go to float64 directly (a strong attack, a 16-bit capture): quiet
    # frames gain the float32 pass, loud ones lose little against float64 alone. Every formulation without a float
    # copy (einsum with a float64 dtype, vecdot casting int16) was slower, and smaller chunks cost more in calls
    # than they save in cache. A compiled one-pass loop with int64 sums is faster still, but numba's import and
    # first call cost every process more CPU than the loop saves in a default run.
    # Measured: docs/bench/detector.md (this kernel against its bound), docs/bench/compiled.md (against numba).
    sumsq = np.empty(n_rows)
    s32 = np.empty((n_rows, 1, 1), np.float32)
    j = n_rows                                                  # the chirps from j on go to float64 at once
    for i in [0, *range(32, n_rows, 256)] if n_rows else []:    # a first chunk of 32 chirps probes the frame
        rows = flat[i: i + (256 if i else 32)]
        x = rows.astype(np.float32)
        out32 = s32[i: i + rows.shape[0]]
        np.matmul(x[:, None, :], x[:, :, None], out=out32)
        if out32.max() >= _EXACT_F32 and np.count_nonzero(out32 >= _EXACT_F32) * 6 > rows.shape[0]:
            j = i
            break
    for i in range(j, n_rows, 256):
        x = flat[i: i + 256].astype(np.float64)
        np.matmul(x[:, None, :], x[:, :, None], out=sumsq[i: i + 256, None, None])
    s32 = s32[:j].reshape(j)
    sumsq[:j] = s32
    redo = np.flatnonzero(s32 >= _EXACT_F32)
    for g in range(0, redo.size, 256):
        r = redo[g: g + 256]
        x = flat[r].astype(np.float64)
        sumsq[r] = np.matmul(x[:, None, :], x[:, :, None]).reshape(r.size)
    return float(lsb) * np.sqrt(sumsq / max(n_samples, 1)).reshape(lead)


def adc_chirp_rms(codes, lsb: float | None, iq: bool, nonfinite=None, *, receivers: bool = False) -> np.ndarray:
    """RMS of every chirp (n_cycles, n_chirps) from what an ADC delivered: exact sums over int16 codes times the
    ADC step `lsb` (the receiver's, carav_stream.radar.adc.adc_step), or `chirp_rms` of an ideal ADC's float
    samples (lsb None; NaN for a chirp with a NaN/Inf sample). `nonfinite` (one count per cycle of NaN/Inf samples
    the ADC met): the cycles with a count above 0 get NaN rows, so the detector judges them invalid.
    `receivers`: a receiver axis before the chirps' (n_cycles, n_rx, n_chirps, ...), combined per chirp."""
    c = np.asarray(codes)
    if c.dtype != np.int16:
        rms = chirp_rms(c, receivers=receivers)
    elif lsb is None:
        raise ValueError("codes: int16 ADC codes need the ADC step lsb")
    else:
        rms = chirp_rms_codes(c, lsb, iq, receivers=receivers)
    if nonfinite is not None:
        rms[np.asarray(nonfinite) > 0] = np.nan
    return rms


def check_rho(rho, n_chirps: int, n_cycles: int | None = None) -> np.ndarray:
    """Validate an activation sequence and return it as bool, shape (n_chirps,) or (n_cycles, n_chirps).

    rho must hold only 0/1 (or bool), have n_chirps entries on its last axis, n_chirps must be even and every row
    must be balanced: exactly n_chirps / 2 active chirps (Algorithm 1, step 1).
    """
    r = np.asarray(rho)
    if r.dtype != np.bool_:
        if not (np.issubdtype(r.dtype, np.integer) or np.issubdtype(r.dtype, np.floating)):
            raise TypeError(f"rho: dtype {r.dtype} is not supported; expected bool or 0/1 integers")
        if not np.all((r == 0) | (r == 1)):
            bad = r[(r != 0) & (r != 1)].ravel()[0]
            raise ValueError(f"rho: values must be 0 or 1, found {bad.item()!r}")
        r = r.astype(bool)
    if r.ndim not in (1, 2):
        raise ValueError(f"rho: expected shape (n_chirps,) or (n_cycles, n_chirps), got {r.shape}")
    if r.shape[-1] != n_chirps:
        raise ValueError(f"rho: has {r.shape[-1]} entries per cycle but the frames have {n_chirps} chirps")
    if n_chirps < 2 or n_chirps % 2:
        raise ValueError(f"rho: n_chirps must be even and >= 2 for a balanced activation sequence, got {n_chirps}")
    if r.ndim == 2 and n_cycles is not None and r.shape[0] != n_cycles:
        raise ValueError(f"rho: has {r.shape[0]} cycles but the frames have {n_cycles}")
    counts = np.atleast_1d(r.sum(axis=-1))
    bad = np.flatnonzero(counts != n_chirps // 2)
    if bad.size:
        raise ValueError(f"rho: not balanced: cycle {bad[0]} has {counts[bad[0]]} active chirps, expected exactly "
                         f"{n_chirps // 2} (half of {n_chirps})")
    return r


def _check_sigma(sigma_n, n_cycles: int) -> np.ndarray:
    """sigma_n as float64 (n_cycles, 1), checked (a float is checked as a Python float, without numpy's calls:
    the detector node calls this once per frame)."""
    if isinstance(sigma_n, float):
        if not (math.isfinite(sigma_n) and sigma_n >= 0):
            raise ValueError(f"sigma_n: must be finite and >= 0, got {sigma_n!r}")
        return np.full((n_cycles, 1), float(sigma_n))
    s = np.asarray(sigma_n, dtype=np.float64)
    if s.ndim > 1 or (s.ndim == 1 and s.shape[0] not in (1, n_cycles)):
        raise ValueError(f"sigma_n: expected a scalar or one value per cycle ({n_cycles}), got shape {s.shape}")
    if not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"sigma_n: must be finite and >= 0, got {sigma_n!r}")
    return np.broadcast_to(s, (n_cycles,))[:, None]


def _check_eta(eta) -> float:
    e = float(eta)
    if not np.isfinite(e) or e <= 0:
        raise ValueError(f"eta: must be finite and > 0, got {eta!r}")
    return e


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den for num, den >= 0 with x/0 = inf (x > 0), 0/0 = 0; NaN stays NaN. No warnings."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = num / den
        zero = den == 0
        if np.any(zero):
            out = np.where(zero, np.where(num > 0, np.inf, np.where(num == 0, 0.0, np.nan)), out)
    return out


def detect_from_rms(rms, rho, sigma_n, eta: float = PAPER_ETA) -> Detection:
    """CARAV detector from per-chirp RMS values (what `detect` computes after `chirp_rms`).

    rms      float (n_chirps,) or (n_cycles, n_chirps), >= 0 or NaN (invalid chirp)
    rho      bool/0-1 (n_chirps,) shared by all cycles, or (n_cycles, n_chirps); balanced
    sigma_n  noise RMS (same unit as rms): scalar or (n_cycles,), finite, >= 0
    eta      threshold > 0 (paper: 1.5)
    """
    r = np.asarray(rms, dtype=np.float64)
    if r.ndim not in (1, 2):
        raise ValueError(f"rms: expected shape (n_chirps,) or (n_cycles, n_chirps), got {r.shape}")
    single = r.ndim == 1
    r2 = np.atleast_2d(r)
    n_cycles, n_chirps = r2.shape
    active = check_rho(rho, n_chirps, n_cycles)
    if active.shape != r2.shape:
        active = np.broadcast_to(np.atleast_2d(active), r2.shape)
    sigma = _check_sigma(sigma_n, n_cycles)
    e = _check_eta(eta)

    invalid = ~np.all(np.isfinite(r2), axis=-1)
    rbar = np.sum(np.where(active, r2, 0.0), axis=-1) / (n_chirps // 2)
    with np.errstate(invalid="ignore", over="ignore"):
        d0 = _ratio(r2, sigma)
        d1 = _ratio(np.abs(r2 - rbar[:, None]), rbar[:, None] + sigma)
    d = np.where(active, d1, d0)
    safe = np.where(np.isnan(d), -np.inf, d)
    k_max = np.argmax(safe, axis=-1)
    rows = np.arange(n_cycles)
    q = d[rows, k_max]
    by_d1 = active[rows, k_max]
    q = np.where(invalid, np.inf, q)
    k_max = np.where(invalid, -1, k_max)
    by_d1 &= ~invalid
    c = q / e
    alarm = (c >= 1.0) | invalid
    if single:
        return Detection(r2[0], d0[0], d1[0], d[0], rbar[0], q[0], c[0], alarm[0], invalid[0], k_max[0], by_d1[0], e)
    return Detection(r2, d0, d1, d, rbar, q, c, alarm, invalid, k_max, by_d1, e)


def detect(frames, rho, sigma_n, eta: float = PAPER_ETA, *, receivers: bool = False) -> Detection:
    """CARAV detector C(eta) on raw ADC frames (Algorithm 1, steps 3-5).

    frames     float32 | float64 | complex64 | complex128, (n_chirps, n_samples) for one cycle or
               (n_cycles, n_chirps, n_samples) for a batch; with receivers=True a receiver axis before the chirps':
               (n_rx, n_chirps, n_samples) or (n_cycles, n_rx, n_chirps, n_samples), judged on the RMS of each
               chirp over all its receivers' samples
    rho        (n_chirps,) or (n_cycles, n_chirps) balanced activation sequence(s)
    sigma_n    noise RMS per sample (of every receiver), same unit as the samples (scalar or (n_cycles,))
    eta        threshold > 0
    """
    x = _check_frames(frames)
    lead = 1 if receivers else 0
    if x.ndim not in (2 + lead, 3 + lead):
        rx = "n_rx, " if receivers else ""
        raise ValueError(f"frames: expected shape ({rx}n_chirps, n_samples) or (n_cycles, {rx}n_chirps, n_samples), "
                         f"got {x.shape}")
    rho_arr = np.asarray(rho)
    if x.ndim == 2 + lead and rho_arr.ndim == 2:
        raise ValueError(f"rho: got shape {rho_arr.shape} (a batch) for a single cycle of shape {x.shape}")
    check_rho(rho_arr, x.shape[-2], x.shape[0] if x.ndim == 3 + lead else None)
    return detect_from_rms(chirp_rms(x, receivers=receivers), rho_arr, sigma_n, eta)


def estimate_sigma_n(calibration_frames, rho, *, confidence: float | None = None):
    """Estimate the noise RMS sigma_n from attack-free calibration cycles.

    Uses only the silent chirps (rho = 0), which hold noise alone:  sigma_hat^2 = mean over silent chirps of
    ||R_k||_r^2 (the maximum-likelihood estimate for white Gaussian noise; E ||n||_r^2 = sigma_n^2 for I-only and
    for I/Q with sigma_n^2 / 2 per component).

    calibration_frames  (n_chirps, n_samples) or (n_cycles, n_chirps, n_samples), supported float/complex dtype
    rho                 matching activation sequence(s)
    confidence          if given (e.g. 0.95), also return the exact chi-square interval under Gaussian noise
    returns             sigma_hat, or (sigma_hat, low, high)

    RISK: the estimate is only as trustworthy as the calibration. Calibrating while an attacker transmits (an
    attacker of RMS sigma_a present on every chirp) inflates the estimate to sqrt(sigma_n^2 + sigma_a^2): every D0
    then shrinks by that factor and the attacker, or any weaker one, is no longer seen by D0. Calibrate in a
    controlled environment (or with the receiver input terminated), keep the value fixed, and never re-estimate it
    from live traffic; a large drift of the estimate is itself a warning sign.
    """
    x = _check_frames(calibration_frames)
    if x.ndim == 2:
        x = x[None]
    if x.ndim != 3:
        raise ValueError(f"calibration_frames: expected (n_chirps, n_samples) or (n_cycles, n_chirps, n_samples), "
                         f"got {x.shape}")
    active = np.broadcast_to(np.atleast_2d(check_rho(rho, x.shape[1], x.shape[0])), x.shape[:2])
    rms = chirp_rms(x)
    silent = rms[~active]
    if not np.all(np.isfinite(silent)):
        raise ValueError("calibration_frames: silent chirps hold NaN or Inf samples; calibration needs clean frames")
    # mean of squares computed via a scaled form so that huge/tiny values do not overflow/underflow
    top = float(np.max(silent)) if silent.size else 0.0
    sigma = top * float(np.sqrt(np.mean((silent / top) ** 2))) if top > 0 else 0.0
    if confidence is None:
        return sigma
    from scipy import stats

    if not 0 < confidence < 1:
        raise ValueError(f"confidence: must be in (0, 1), got {confidence!r}")
    dof = silent.size * x.shape[-1] * (2 if np.iscomplexobj(x) else 1)
    alpha = 1.0 - confidence
    low = sigma * np.sqrt(dof / stats.chi2.isf(alpha / 2, dof))
    high = sigma * np.sqrt(dof / stats.chi2.ppf(alpha / 2, dof))
    return sigma, float(low), float(high)
