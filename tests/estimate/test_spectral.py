"""Frequency kernels against closed forms and scipy references."""
import numpy as np
import pytest
import scipy.optimize
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.estimate import spectral


def _tone(n, f, phase=0.3):
    return np.exp(2j * np.pi * (f * np.arange(n)) + 1j * phase)


@settings(max_examples=40, deadline=None)
@given(st.floats(-0.49, 0.49), st.integers(16, 512))
def test_candan_recovers_sub_bin_offset_of_noise_free_tone(delta, n):
    k = n // 4
    x = np.fft.fft(_tone(n, (k + delta) / n))
    est = spectral.candan_delta(x[k - 1], x[k], x[k + 1], n)
    assert est == pytest.approx(delta, abs=2e-3)


@settings(max_examples=30, deadline=None)
@given(st.floats(0.05, 0.45), st.floats(-0.45, 0.45))
def test_newton_refine_converges_on_noise_free_tone(f, offset_bins):
    n = 256
    got = spectral.newton_refine(_tone(n, f), np.array(f + offset_bins * 0.2 / n), n_iter=4)
    assert got == pytest.approx(f, abs=1e-9)


def test_newton_refine_matches_scipy_periodogram_maximiser_on_noisy_data():
    rng = np.random.default_rng(3)
    n = 200
    t = np.arange(n)
    y = _tone(n, 0.1234) + 0.5 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    ref = scipy.optimize.minimize_scalar(lambda f: -abs(np.sum(y * np.exp(-2j * np.pi * f * t))) ** 2,
                                         bounds=(0.1234 - 0.5 / n, 0.1234 + 0.5 / n), method="bounded",
                                         options={"xatol": 1e-12}).x
    k = int(round(0.1234 * n))
    x = np.fft.fft(y)
    start = (k + spectral.candan_delta(x[k - 1], x[k], x[k + 1], n)) / n
    assert spectral.newton_refine(y, np.array(start), n_iter=3) == pytest.approx(ref, abs=1e-8)


def test_newton_refine_handles_sparse_sample_times():
    times = np.sort(np.random.default_rng(5).choice(64, 32, replace=False)).astype(float)
    y = np.zeros(64, complex)
    y[times.astype(int)] = np.exp(2j * np.pi * 0.071 * times)
    got = spectral.newton_refine(y, np.array(0.071 + 0.2 / 64), n_iter=6, times=np.arange(64.0))
    assert got == pytest.approx(0.071, abs=1e-9)


def test_music_pseudospectrum_and_root_music_find_two_close_tones():
    n, f1, f2 = 128, 0.2, 0.2 + 0.6 / 128  # 0.6 bin apart: below the periodogram's resolution
    y = _tone(n, f1) + 0.8 * _tone(n, f2, 1.1)
    cov = spectral.fb_covariance(y, 48)
    _, sig = spectral.subspaces(cov, 2)
    roots, mags = spectral.root_music_roots(sig, 2)
    assert np.sort(roots) == pytest.approx([f1, f2], abs=1e-6)
    pseudo2 = spectral.music_pseudospectrum(sig, 1 << 16)
    peaks = np.argsort(pseudo2)[-50:] / (1 << 16)
    assert np.min(np.abs(peaks - f1)) < 2e-5 and np.min(np.abs(peaks - f2)) < 2e-5


@pytest.mark.parametrize("n_tones", [0, 1, 2, 3])
@pytest.mark.parametrize("criterion", ["mdl", "aic"])
def test_information_criterion_counts_tones_in_noise(n_tones, criterion):
    rng = np.random.default_rng(n_tones)
    n = 400
    y = sum(_tone(n, f, rng.random() * 6) for f in [0.1, 0.27, 0.4][:n_tones]) \
        + 0.3 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    cov = spectral.fb_covariance(y, 12)
    eig = np.linalg.eigvalsh(cov)
    assert spectral.information_criterion_order(eig, n // 12, criterion=criterion) == n_tones


def test_information_criterion_gives_rank_of_noise_free_covariance():
    y = _tone(300, 0.1) + _tone(300, 0.3)
    eig = np.linalg.eigvalsh(spectral.fb_covariance(y, 10))
    assert spectral.information_criterion_order(eig, 30) == 2


def test_information_criterion_rejects_unknown_criterion():
    with pytest.raises(ValueError, match="criterion.*'bic'"):
        spectral.information_criterion_order(np.ones(4), 10, criterion="bic")


@pytest.mark.parametrize("n_len", [1, 2, 7, 64, 127, 1100])
@pytest.mark.parametrize("sign", [-1.0, 1.0])
def test_phasor_matches_complex_exponential(n_len, sign):
    f = np.array([[0.0, 0.123456789], [-0.4999, 0.37]])
    n = np.arange(n_len)
    for origin in (0.0, 0.5 * (n_len - 1)):
        ref = np.exp(sign * 2j * np.pi * f[..., None] * (n - origin))
        got = spectral.phasor(f, n_len, sign, origin=origin)
        assert got.shape == (2, 2, n_len)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
