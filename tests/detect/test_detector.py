"""CARAV detector kernels: golden values from the paper's formulas written independently, invariants, errors."""
from __future__ import annotations

import warnings
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from carav_stream.detect.detector import chirp_rms, detect, detect_from_rms, estimate_sigma_n


def _reference_q(frames: np.ndarray, rho: np.ndarray, sigma_n: float) -> float:
    """Q of one cycle straight from Section V.A with Python floats (no numpy vectorisation)."""
    rms = [float(np.sqrt(np.mean(np.abs(np.asarray(c, dtype=np.complex128)) ** 2))) for c in frames]
    active = [r for r, a in zip(rms, rho) if a]
    rbar = sum(active) / (len(rho) / 2)
    d = [abs(r - rbar) / (rbar + sigma_n) if a else r / sigma_n for r, a in zip(rms, rho)]
    return max(d)


def _rho(n_chirps: int, rng: np.random.Generator) -> np.ndarray:
    rho = np.zeros(n_chirps, dtype=bool)
    rho[rng.permutation(n_chirps)[: n_chirps // 2]] = True
    return rho


def test_chirp_rms_matches_exact_fractions_on_small_chirp():
    x = np.array([[3.0, -4.0, 1.5e-3, 2.0 ** -30]])
    exact = sum(Fraction(v) ** 2 for v in x[0]) / 4
    assert chirp_rms(x)[0] == pytest.approx(float(exact) ** 0.5, rel=1e-15)


def test_chirp_rms_of_iq_uses_modulus_over_complex_samples():
    x = np.array([[3 + 4j, 0 + 0j]], dtype=np.complex64)
    assert chirp_rms(x)[0] == pytest.approx(np.sqrt(25 / 2), rel=1e-7)


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.complex64, np.complex128])
def test_detect_matches_paper_formula_for_every_dtype(dtype):
    rng = np.random.default_rng(11)
    rho = _rho(16, rng)
    frames = rng.standard_normal((16, 40)) * 0.7
    if np.dtype(dtype).kind == "c":
        frames = frames + 1j * rng.standard_normal((16, 40)) * 0.7
    frames[rho] += 2.0 * np.cos(0.3 * np.arange(40))
    frames = frames.astype(dtype)
    det = detect(frames, rho, sigma_n=0.8, eta=1.5)
    tol = 1e-6 if np.dtype(dtype) in (np.float32, np.complex64) else 1e-13
    assert det.q == pytest.approx(_reference_q(frames, rho, 0.8), rel=tol)
    assert det.alarm == (det.q / 1.5 >= 1)


def test_detect_batch_equals_cycle_by_cycle():
    rng = np.random.default_rng(3)
    rho = np.array([_rho(8, rng) for _ in range(5)])
    frames = rng.standard_normal((5, 8, 30)) * np.array([1, 1, 3, 1, 1])[:, None, None]
    batch = detect(frames, rho, 1.0)
    for i in range(5):
        one = detect(frames[i], rho[i], 1.0)
        assert one.q == batch.q[i]
        np.testing.assert_array_equal(one.d, batch.d[i])


def test_detect_uses_d0_on_silent_and_d1_on_active_chirps():
    rho = np.array([1, 0, 1, 0], dtype=bool)
    rms = np.array([2.0, 0.5, 4.0, 3.0])
    det = detect_from_rms(rms, rho, sigma_n=1.0, eta=1.5)
    rbar = 3.0
    np.testing.assert_allclose(det.d, [abs(2 - rbar) / (rbar + 1), 0.5, abs(4 - rbar) / (rbar + 1), 3.0])
    assert det.q == 3.0 and det.k_max == 3 and not det.by_d1 and det.alarm


def test_alarm_fires_exactly_at_c_equal_one():
    rho = np.array([1, 0], dtype=bool)
    det = detect_from_rms(np.array([1.0, 1.5]), rho, sigma_n=1.0, eta=1.5)
    assert det.c == 1.0 and det.alarm
    det = detect_from_rms(np.array([1.0, np.nextafter(1.5, 0)]), rho, sigma_n=1.0, eta=1.5)
    assert not det.alarm


def test_detector_flags_nan_frame_as_invalid_alarm_never_clean():
    rng = np.random.default_rng(0)
    frames = rng.standard_normal((3, 4, 16)).astype(np.float32)
    frames[1, 2, 5] = np.nan
    frames[2, 0, 0] = np.inf
    det = detect(frames, np.array([1, 1, 0, 0]), 1.0, eta=1e9)
    np.testing.assert_array_equal(det.invalid, [False, True, True])
    np.testing.assert_array_equal(det.alarm, [False, True, True])
    assert np.isinf(det.q[1]) and np.isinf(det.q[2]) and det.k_max[1] == -1


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([np.float32, np.float64, np.complex64, np.complex128]),
       st.integers(-30, 30))
def test_q_is_invariant_when_samples_and_sigma_are_scaled_together(seed, dtype, exponent):
    rng = np.random.default_rng(seed)
    rho = _rho(8, rng)
    base = rng.standard_normal((8, 24)) * rng.uniform(0.01, 10, size=(8, 1))
    if np.dtype(dtype).kind == "c":
        base = base + 1j * rng.standard_normal((8, 24))
    sigma = float(rng.uniform(0.1, 3))
    factor = 10.0 ** exponent
    ref = detect(base.astype(dtype), rho, sigma).q
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scaled = detect((base * factor).astype(dtype), rho, sigma * factor).q
    tol = 3e-6 if np.dtype(dtype) in (np.float32, np.complex64) else 1e-12
    assert scaled == pytest.approx(ref, rel=tol)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_permuting_chirps_with_rho_and_samples_within_chirps_leaves_q_unchanged(seed):
    rng = np.random.default_rng(seed)
    rho = _rho(10, rng)
    frames = rng.standard_normal((10, 17)) * rng.uniform(0.1, 5, size=(10, 1))
    q = detect(frames, rho, 1.3).q
    perm = rng.permutation(10)
    assert detect(frames[perm], rho[perm], 1.3).q == pytest.approx(q, rel=1e-14)
    within = np.take_along_axis(frames, np.argsort(rng.random((10, 17)), axis=1), axis=1)
    assert detect(within, rho, 1.3).q == pytest.approx(q, rel=1e-14)


@settings(max_examples=30, deadline=None)
@given(hnp.arrays(np.float64, (4, 6), elements=st.floats(-1e300, 1e300, allow_nan=False)))
def test_chirp_rms_never_overflows_or_underflows_for_finite_float64(x):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rms = chirp_rms(x)
    assert np.all(np.isfinite(rms))
    exact = []
    for row in x:
        top = Fraction(float(np.max(np.abs(row))))
        exact.append(float(top) * float(sum((Fraction(v) / top) ** 2 for v in row) / 6) ** 0.5 if top else 0.0)
    np.testing.assert_allclose(rms, exact, rtol=1e-14, atol=0)


def test_chirp_rms_handles_extreme_float64_magnitudes():
    x = np.array([[1e300, 1e300], [1e-300, -1e-300], [5e-324, 0.0], [0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rms = chirp_rms(x)
    np.testing.assert_allclose(rms, [1e300, 1e-300, 5e-324 / np.sqrt(2), 0.0], rtol=1e-15)


def test_sigma_zero_and_all_zero_chirps_give_documented_values_without_warnings():
    rho = np.array([1, 1, 0, 0], dtype=bool)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        quiet = detect(np.zeros((4, 8)), rho, sigma_n=0.0)
        assert quiet.q == 0.0 and not quiet.alarm and not quiet.invalid     # 0/0 -> 0, Rbar + sigma = 0
        leak = np.zeros((4, 8))
        leak[3, 0] = 1e-20
        noisy = detect(leak, rho, sigma_n=0.0)
        assert np.isinf(noisy.q) and noisy.alarm and not noisy.by_d1       # x/0 -> inf on a silent chirp
        zeros = detect(np.zeros((4, 8)), rho, sigma_n=1.0)
        assert zeros.q == 0.0 and zeros.rbar == 0.0


def test_detect_rejects_unbalanced_rho_naming_cycle_and_count():
    with pytest.raises(ValueError, match=r"rho: not balanced: cycle 1 has 3 active chirps, expected exactly 2"):
        detect(np.zeros((2, 4, 8)), np.array([[1, 1, 0, 0], [1, 1, 1, 0]]), 1.0)


def test_detect_rejects_rho_length_mismatch():
    with pytest.raises(ValueError, match=r"rho: has 6 entries per cycle but the frames have 4 chirps"):
        detect(np.zeros((4, 8)), np.array([1, 1, 1, 0, 0, 0]), 1.0)


def test_detect_rejects_non_binary_rho_and_integer_frames():
    with pytest.raises(ValueError, match=r"rho: values must be 0 or 1, found 2"):
        detect(np.zeros((4, 8)), np.array([2, 1, 0, 0]), 1.0)
    with pytest.raises(TypeError, match=r"frames: dtype int16 is not supported"):
        detect(np.zeros((4, 8), dtype=np.int16), np.array([1, 1, 0, 0]), 1.0)


def test_detect_rejects_negative_sigma_and_bad_eta():
    rho = np.array([1, 1, 0, 0])
    with pytest.raises(ValueError, match=r"sigma_n: must be finite and >= 0, got -1"):
        detect(np.zeros((4, 8)), rho, -1.0)
    with pytest.raises(ValueError, match=r"eta: must be finite and > 0, got 0"):
        detect(np.zeros((4, 8)), rho, 1.0, eta=0)


def test_estimate_sigma_n_recovers_noise_level_from_silent_chirps_only():
    rng = np.random.default_rng(8)
    rho = np.tile(np.r_[np.ones(16, bool), np.zeros(16, bool)], (50, 1))
    frames = 2.5 * (rng.standard_normal((50, 32, 128)) + 1j * rng.standard_normal((50, 32, 128))) / np.sqrt(2)
    frames[:, :16] += 40.0                                   # huge echoes on active chirps must be ignored
    sigma, low, high = estimate_sigma_n(frames, rho, confidence=0.95)
    assert low < 2.5 < high and sigma == pytest.approx(2.5, rel=0.01)


def test_estimate_sigma_n_refuses_calibration_frames_with_nan():
    frames = np.ones((4, 8))
    frames[3, 1] = np.nan
    with pytest.raises(ValueError, match="calibration_frames: silent chirps hold NaN"):
        estimate_sigma_n(frames, np.array([1, 1, 0, 0]))


def test_chirp_rms_accepts_a_single_chirp_including_degenerate_ones():
    assert chirp_rms(np.array([3.0, -3.0])) == 3.0
    assert chirp_rms(np.zeros(5, dtype=np.float32)) == 0.0
    assert np.isnan(chirp_rms(np.array([np.inf, 1.0])))
    assert chirp_rms(np.array([1e300, -1e300])) == pytest.approx(1e300, rel=1e-15)


def test_chirp_rms_from_integer_codes_is_exact_for_i_only_and_iq_up_to_full_scale():
    from fractions import Fraction

    from carav_stream.detect.detector import chirp_rms_codes
    rng = np.random.default_rng(3)
    codes = rng.integers(-32768, 32768, size=(2, 3, 1000, 2)).astype(np.int16)
    codes[0, 0] = -32768                                     # every sample on the negative rail
    for iq, c in ((True, codes), (False, codes[..., 0])):
        got = chirp_rms_codes(c, 0.5, iq=iq)
        n = c.shape[2]
        for idx in np.ndindex(got.shape):
            exact = Fraction(int(np.sum(c[idx].astype(object) ** 2)), n)   # exact mean square
            assert got[idx] == 0.5 * np.sqrt(float(exact))
    with pytest.raises(TypeError, match="integer"):
        chirp_rms_codes(codes.astype(np.float32), 1.0)
    with pytest.raises(ValueError, match="last axis of 2"):
        chirp_rms_codes(codes[..., 0], 1.0, iq=True)
