"""CARAV over a receiver array: the combined RMS against the receivers' samples laid side by side, per-receiver
diagnostics against detect() on each receiver alone, the steering's gains against an eigendecomposition, and the
law of a silent chirp against scipy's chi-square, a direct integration and a Monte Carlo of its weighted sum."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from carav_stream.detect.detector import adc_chirp_rms, chirp_rms, chirp_rms_codes, detect
from carav_stream.detect.receivers import (
    per_receiver_detect,
    per_receiver_from_rms,
    per_receiver_q,
    silent_log_cdf,
    steering_gains,
)
from carav_stream.detect.stats import clopper_pearson, pf_pm_closed_form

DTYPES = [np.float32, np.float64, np.complex64, np.complex128]


def _side_by_side(frames: np.ndarray) -> np.ndarray:
    """(..., n_rx, n_chirps, n_samples) -> (..., n_chirps, n_rx * n_samples) by concatenating the receivers."""
    return np.concatenate([frames[..., r, :, :] for r in range(frames.shape[-3])], axis=-1)


def _balanced(rng: np.random.Generator, n_cycles: int, n_chirps: int) -> np.ndarray:
    keys = rng.random((n_cycles, n_chirps))
    return keys < np.median(keys, axis=1, keepdims=True)


@settings(max_examples=60)
@given(seed=st.integers(0, 2 ** 32 - 1), dtype=st.sampled_from(DTYPES),
       shape=st.tuples(st.integers(1, 3), st.integers(1, 5), st.integers(1, 6), st.integers(1, 9)),
       log_scale=st.sampled_from([-200, -20, 0, 20, 150]), nan=st.booleans())
def test_combined_rms_is_the_rms_of_the_receivers_samples_side_by_side(seed, dtype, shape, log_scale, nan):
    """Any dtype, any size, scales that overflow or underflow a float64 sum of squares, a NaN on one receiver."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(shape)
    if np.dtype(dtype).kind == "c":
        x = x + 1j * rng.standard_normal(shape)
    if np.dtype(dtype) in (np.float32, np.complex64):
        log_scale = max(min(log_scale, 30), -30)
    x = (x * 10.0 ** log_scale).astype(dtype)
    if nan:
        x[tuple(rng.integers(0, n) for n in shape)] = np.nan
    got = chirp_rms(x, receivers=True)
    want = chirp_rms(_side_by_side(x))
    assert got.shape == shape[:1] + shape[2:3]
    # the same sums of the same numbers; numpy's vector loops may add them in another order (alignment): ulps apart
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=0, equal_nan=True)
    if nan:
        assert np.isnan(got).sum() == 1


@pytest.mark.parametrize("iq", [False, True])
def test_combined_rms_of_codes_is_exact_over_every_receivers_codes(iq):
    rng = np.random.default_rng(3)
    codes = rng.integers(-2 ** 15, 2 ** 15, size=(2, 4, 6, 50, 2) if iq else (2, 4, 6, 50)).astype(np.int16)
    got = chirp_rms_codes(codes, 0.25, iq, receivers=True)
    wide = codes.astype(np.int64)
    exact = np.sqrt(np.sum(wide ** 2, axis=(1, 3, 4) if iq else (1, 3)) / (4 * 50))     # integer sums, then one root
    assert got.shape == (2, 6) and np.array_equal(got, 0.25 * exact)
    assert np.array_equal(adc_chirp_rms(codes, 0.25, iq, receivers=True), got)


def test_a_nan_on_one_receiver_makes_the_cycle_invalid_and_the_others_unchanged():
    rng = np.random.default_rng(5)
    rho = _balanced(rng, 3, 8)
    frames = rng.standard_normal((3, 4, 8, 20)).astype(np.float32)
    clean = detect(frames, rho, 1.0, receivers=True)
    frames[1, 3, 2, 7] = np.nan
    d = detect(frames, rho, 1.0, receivers=True)
    assert d.invalid.tolist() == [False, True, False] and d.alarm[1] and d.q[1] == np.inf and d.k_max[1] == -1
    assert np.array_equal(d.q[[0, 2]], clean.q[[0, 2]])
    assert np.isnan(adc_chirp_rms(frames, None, False, receivers=True)[1, 2])
    nonfinite = adc_chirp_rms(frames[[0, 2]], None, False, [0, 4], receivers=True)
    assert np.all(np.isnan(nonfinite[1])) and np.all(np.isfinite(nonfinite[0]))


def test_one_receiver_with_a_receiver_axis_is_the_one_receiver_detector_bit_for_bit():
    rng = np.random.default_rng(6)
    rho = _balanced(rng, 4, 16)
    frames = (rng.standard_normal((4, 16, 30)) + 1j * rng.standard_normal((4, 16, 30))).astype(np.complex64)
    a, b = detect(frames, rho, 0.9), detect(frames[:, None], rho, 0.9, receivers=True)
    for field in ("rms", "q", "d0", "d1", "k_max", "alarm"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    one = detect(frames[0][None], rho[0], 0.9, receivers=True)                # one cycle: (n_rx, n_chirps, n_samples)
    assert one.q.shape == () and one.q == a.q[0]


def test_detect_with_receivers_refuses_frames_without_a_receiver_axis():
    with pytest.raises(ValueError, match=r"n_rx, n_chirps, n_samples.*got \(16, 30\)"):
        detect(np.zeros((16, 30)), np.arange(16) % 2, 1.0, receivers=True)
    with pytest.raises(ValueError, match="receiver axis"):
        chirp_rms(np.zeros((16, 30)), receivers=True)


@pytest.mark.parametrize("dtype", DTYPES)
def test_per_receiver_q_is_detect_on_each_receiver_alone(dtype):
    rng = np.random.default_rng(8)
    n_cycles, n_rx, n_chirps, n_s = 5, 3, 12, 25
    rho = _balanced(rng, n_cycles, n_chirps)
    x = rng.standard_normal((n_cycles, n_rx, n_chirps, n_s))
    if np.dtype(dtype).kind == "c":
        x = x + 1j * rng.standard_normal(x.shape)
    x[:, 1] *= 1.6                                            # receiver 1 louder: its own Q differs
    x = x.astype(dtype)
    sigma = np.array([1.0, 1.1, 0.9, 1.2, 1.05])
    d = per_receiver_detect(x, rho, sigma, eta=1.4)
    assert d.q.shape == (n_cycles, n_rx) and d.rms.shape == (n_cycles, n_rx, n_chirps)
    for i in range(n_cycles):
        for r in range(n_rx):
            alone = detect(x[i, r], rho[i], sigma[i], eta=1.4)
            assert d.q[i, r] == alone.q and d.alarm[i, r] == alone.alarm and d.k_max[i, r] == alone.k_max
            assert np.array_equal(d.d[i, r], alone.d)
    assert np.array_equal(per_receiver_q(x, rho, sigma), d.q)
    single = per_receiver_detect(x[2], rho[2], sigma[2])
    assert single.q.shape == (n_rx,) and np.array_equal(single.q, d.q[2])


def test_per_receiver_from_rms_refuses_a_sigma_per_cycle_of_the_wrong_length():
    with pytest.raises(ValueError, match=r"sigma_n: .*one value per cycle \(2\)"):
        per_receiver_from_rms(np.ones((2, 3, 4)), [1, 0, 1, 0], np.ones(3))


@pytest.mark.parametrize("n_rx,azimuth_deg", [(2, 17.0), (4, 30.0), (8, -52.0), (3, 0.0)])
def test_steering_gains_are_the_eigenvalues_of_the_attacks_covariance_over_the_receivers(n_rx, azimuth_deg):
    phases = 2 * np.pi * 0.5 * np.arange(n_rx) * np.sin(np.radians(azimuth_deg))
    v = np.exp(1j * phases)
    real = np.linalg.eigvalsh(np.real(np.outer(v, v.conj())))          # I-only: Re(v v^H)
    iq = np.linalg.eigvalsh(np.outer(v, v.conj())).real                 # I/Q: v v^H
    assert steering_gains(phases, False) == pytest.approx(sorted(real[real > 1e-9], reverse=True), abs=1e-9)
    assert steering_gains(phases, True) == pytest.approx(sorted(iq[iq > 1e-9], reverse=True), abs=1e-9)
    assert sum(steering_gains(phases, False)) == pytest.approx(n_rx)


def test_the_law_with_gains_of_one_is_the_chi_square_of_all_the_receivers_samples():
    c = np.array([900.0, 1024.0, 1200.0, 1400.0])
    want = stats.chi2.logcdf(c / 1.25, 4 * 256)
    assert silent_log_cdf(c, dof=256, n_rx=4, rarms=0.5) == pytest.approx(want, rel=1e-12)
    assert silent_log_cdf(c, dof=256, n_rx=4, rarms=0.5, gains=(1, 1, 1, 1)) == pytest.approx(want, rel=1e-12)
    cf4 = pf_pm_closed_form([1.05, 1.1, 1.2], n_chirps=64, dof=256, n_rx=4, snr=2.0)
    cf1 = pf_pm_closed_form([1.05, 1.1, 1.2], n_chirps=64, dof=1024, snr=2.0)
    assert all(np.array_equal(cf4[k], cf1[k]) for k in cf1)                    # nu -> n_rx nu, the same numbers


def test_one_attacker_on_four_receivers_has_the_law_of_a_direct_integration():
    """E = (1 + 4 R^2) X + Y, X ~ chi2(nu), Y ~ chi2(3 nu): P(E >= c) = P(X >= c / w) + int f_X(x) P(Y >= c - w x)."""
    nu, n_rx, rarms = 64, 4, 0.6
    w = 1 + n_rx * rarms ** 2
    mean, sd = w * nu + (n_rx - 1) * nu, np.sqrt(2 * nu * w ** 2 + 2 * (n_rx - 1) * nu)
    for z in (-3.0, 0.0, 2.0, 5.0):
        c = mean + z * sd
        sf = stats.chi2.sf(c / w, nu) + integrate.quad(
            lambda x: stats.chi2.pdf(x, nu) * stats.chi2.sf(c - w * x, (n_rx - 1) * nu), 0, c / w,
            epsabs=0, epsrel=1e-12, limit=400)[0]
        got = silent_log_cdf(c, dof=nu, n_rx=n_rx, rarms=rarms, gains=(4.0,))
        assert -np.expm1(got) == pytest.approx(sf, rel=1e-8, abs=1e-13), z


def test_an_i_only_attacker_off_broadside_has_the_law_of_its_weighted_chi_squares():
    """Two gains and a noise-only remainder: Monte Carlo of sum_j w_j chi2(k_j), a million draws, 99.9 % intervals."""
    nu, rarms = 20, 0.8
    gains = steering_gains(2 * np.pi * 0.5 * np.arange(4) * np.sin(np.radians(20.0)), iq=False)
    assert len(gains) == 2
    rng = np.random.default_rng(11)
    n = 1_000_000
    e = sum((1 + g * rarms ** 2) * rng.chisquare(nu, n) for g in gains) + rng.chisquare(2 * nu, n)
    for c in np.quantile(e, [0.001, 0.05, 0.5, 0.95, 0.999]):
        k = int(np.sum(e < c))
        lo, hi = clopper_pearson(k, n, 0.999)
        assert lo <= np.exp(silent_log_cdf(c, dof=nu, n_rx=4, rarms=rarms, gains=gains)) <= hi


def test_the_closed_form_refuses_gains_that_do_not_sum_to_the_receivers():
    with pytest.raises(ValueError, match=r"attack_gains: .*summing to n_rx = 4"):
        pf_pm_closed_form(1.2, n_chirps=8, dof=16, rarms=1.0, n_rx=4, attack_gains=(2.0, 1.0))
    with pytest.raises(ValueError, match="n_rx: must be an integer >= 1, got 0"):
        pf_pm_closed_form(1.2, n_chirps=8, dof=16, n_rx=0)
