"""The detector's per-frame path against plain references: exact int64 sums of squares of the ADC codes, and the
verdict picked from D(k) chirp by chirp in Python.

    ||R_k||_r = lsb sqrt(sum_m code[m]^2 / N_s)       (I/Q: code_I^2 + code_Q^2; an exact integer sum)
    Q = max_k D(k) (first k on ties), by_d1 = rho(k_max); an invalid cycle: Q = inf, k_max = -1, by_d1 False
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.detect.detector import adc_chirp_rms, chirp_rms_codes, detect_from_rms

EDGES = np.array([-32768, 32767, -32767, 0, 1, -1, 2047, -2048], np.int16)


@st.composite
def code_frames(draw):
    """int16 codes (n_cycles, n_chirps, n_samples[, 2]) of random shape (odd lengths, more rows than one chunk of
    the kernel), uniform over int16 or over a 12-bit ADC's codes, with rails, zero chirps and all-zero cycles."""
    iq = draw(st.booleans())
    n_cycles, n_chirps = draw(st.integers(1, 6)), draw(st.sampled_from([1, 2, 5, 64, 130]))
    n_samples = draw(st.sampled_from([1, 2, 3, 7, 64, 255, 1081]))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    shape = (n_cycles, n_chirps, n_samples) + ((2,) if iq else ())
    top = draw(st.sampled_from([1, 2048, 32768]))
    codes = rng.integers(-top, top, size=shape, dtype=np.int64).astype(np.int16)
    flat = codes.reshape(-1)
    hits = rng.random(flat.size) < draw(st.sampled_from([0.0, 0.1, 1.0]))
    flat[hits] = rng.choice(EDGES, size=int(hits.sum()))
    codes[rng.random(n_cycles) < 0.2] = 0                       # all-zero cycles
    codes[:, rng.random(n_chirps) < 0.2] = 0                    # all-zero chirps
    nonfinite = rng.choice([0, 0, 0, 1, 7], size=n_cycles).tolist()
    lsb = draw(st.sampled_from([1.0, 0.5, 2.916976976379289e-06, 3.0]))
    return codes, iq, lsb, nonfinite


def reference_rms(codes: np.ndarray, iq: bool, lsb: float) -> np.ndarray:
    """lsb sqrt(sum code^2 / n) with the sum in exact int64 arithmetic."""
    sq = codes.astype(np.int64) ** 2
    sums = sq.sum(axis=(-2, -1)) if iq else sq.sum(axis=-1)
    n = codes.shape[-2] if iq else codes.shape[-1]
    return float(lsb) * np.sqrt(sums / n)


@settings(max_examples=120, deadline=None)
@given(code_frames())
def test_rms_of_codes_equals_exact_int64_sums_bit_for_bit(frame):
    codes, iq, lsb, nonfinite = frame
    want = reference_rms(codes, iq, lsb)
    got = chirp_rms_codes(codes, lsb, iq=iq)
    assert got.dtype == np.float64 and got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    judged = adc_chirp_rms(codes, lsb, iq, nonfinite)            # what the detector node calls per frame
    want[np.array(nonfinite) > 0] = np.nan
    np.testing.assert_array_equal(judged, want)


def reference_verdict(d: np.ndarray, active: np.ndarray, rms: np.ndarray, eta: float):
    """q, k_max, by_d1, invalid, alarm of one cycle from its D(k), chirp by chirp in Python."""
    if not all(math.isfinite(r) for r in rms):
        return math.inf, -1, False, True, True
    values = [(-math.inf if math.isnan(v) else v) for v in d.tolist()]
    k = values.index(max(values))
    q = float(d[k])
    return q, k, bool(active[k]), False, q / eta >= 1.0


@st.composite
def rms_cases(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    n_cycles, n_chirps = draw(st.integers(1, 6)), 2 * draw(st.integers(1, 33))
    rms = np.abs(rng.standard_normal((n_cycles, n_chirps))) * draw(st.sampled_from([0.0, 1e-4, 1.0, 1e6]))
    holes = rng.random(rms.shape) < draw(st.sampled_from([0.0, 0.05]))
    rms[holes] = rng.choice([np.nan, np.inf, 0.0], size=int(holes.sum()))
    rms[rng.random(n_cycles) < 0.2] = 0.0                        # cycles without any energy
    if draw(st.booleans()):                                      # ties: every chirp of a cycle alike
        rms[0] = rms[0, 0]
    rho = np.zeros((n_cycles, n_chirps), bool)
    for i in range(n_cycles):
        rho[i, rng.permutation(n_chirps)[: n_chirps // 2]] = True
    sigma = float(draw(st.sampled_from([0.0, 1e-4, 0.7, 1.0])))
    eta = float(draw(st.sampled_from([0.5, 1.0, 1.5, 4.0])))
    return rms, rho, sigma, eta


@settings(max_examples=150, deadline=None)
@given(rms_cases())
def test_verdicts_equal_the_formulas_chirp_by_chirp_whatever_form_sigma_takes(case):
    rms, rho, sigma, eta = case
    det = detect_from_rms(rms, rho, sigma, eta)
    n_cycles = rms.shape[0]
    for form in (np.float64(sigma), np.full(n_cycles, sigma), np.array([sigma]), np.array(sigma)):
        other = detect_from_rms(rms, rho, form, eta)
        for name in ("rms", "d0", "d1", "d", "rbar", "q", "c", "alarm", "invalid", "k_max", "by_d1"):
            np.testing.assert_array_equal(getattr(other, name), getattr(det, name), err_msg=f"{name}, {form!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(n_cycles):
            r, a = rms[i], rho[i]
            rbar = det.rbar[i]
            if np.isfinite(r).all():
                assert math.isclose(rbar, math.fsum(r[a]) / (len(r) // 2), rel_tol=1e-14, abs_tol=0.0)
            for k in range(len(r)):
                num, den = abs(r[k] - rbar), rbar + sigma
                d1 = (num / den if den else (math.inf if num > 0 else 0.0 if num == 0 else math.nan))
                d0 = (r[k] / sigma if sigma else (math.inf if r[k] > 0 else 0.0 if r[k] == 0 else math.nan))
                assert np.array_equal([det.d0[i, k], det.d1[i, k]], [d0, d1], equal_nan=True), (i, k)
                assert np.array_equal(det.d[i, k], d1 if a[k] else d0, equal_nan=True)
            q, k_max, by_d1, invalid, alarm = reference_verdict(det.d[i], a, r, eta)
            assert (det.q[i], det.k_max[i], det.by_d1[i], det.invalid[i], det.alarm[i]) == (q, k_max, by_d1,
                                                                                             invalid, alarm)
            assert det.c[i] == q / eta
