"""The subspace methods' beat stage (estimators/_subspace.py): the covariance's products by FFT correlations equal
the covariance formed, subspace iteration finds the dominant eigenvectors' span, and a noise-free tone that starts
inside the window is found exactly."""
import numpy as np

from carav_stream.estimate.estimators import _subspace


def _noisy(rng, n_cycles, n, freqs, snr, onset):
    t = np.arange(n)
    y = sum(np.exp(2j * np.pi * (f * t + rng.uniform(0, 1, (n_cycles, 1)))) for f in freqs)
    y = y * (t >= onset[:, None])
    return y + (rng.standard_normal((n_cycles, n)) + 1j * rng.standard_normal((n_cycles, n))) / np.sqrt(2 * snr)


def test_the_covariance_products_by_correlation_equal_the_formed_covariance():
    rng = np.random.default_rng(1)
    n, length = 97, 24
    y = rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n))
    onset = np.array([0, 5, 40])
    v = rng.standard_normal((3, length, 2)) + 1j * rng.standard_normal((3, length, 2))
    windows, n_windows = _subspace._windows(onset, n, length)
    fast = _subspace.fb_apply(np.fft.fft(y, n=108, axis=-1), windows, n_windows, v, length)
    formed = _subspace._covariance(y, onset, length) @ v
    np.testing.assert_allclose(fast, formed, rtol=0, atol=1e-12 * np.abs(y).max() ** 2)


def test_subspace_iteration_spans_the_dominant_eigenvectors():
    rng = np.random.default_rng(2)
    n, length, onset = 400, 100, np.array([0, 30, 150])
    y = _noisy(rng, 3, n, (0.11, -0.11), 10.0, onset)              # a real tone's two exponentials, at 10 dB
    sig = _subspace.signal_subspace(y, np.array([[0.1102, -0.1102]] * 3), onset, length)
    _, vec = np.linalg.eigh(_subspace._covariance(y, onset, length))
    top = vec[..., -2:]
    proj = np.linalg.norm(np.swapaxes(top.conj(), 1, 2) @ sig, axis=(1, 2)) ** 2   # ||E^H S||_F^2: 2 when equal
    assert np.all(proj > 2 - 1e-6)


def test_a_noise_free_tone_starting_inside_the_window_is_found_exactly():
    f = np.array([0.0713, 0.2501, 0.4102])
    n, length = 512, 128
    onset = np.array([0, 60, 200])
    t = np.arange(n)
    y = np.exp(2j * np.pi * f[:, None] * t) * (t >= onset[:, None])
    beat = _subspace.music_beat(y, (f + 0.15 / n)[:, None], 0, onset, n_per=1, length=length, root=False)
    np.testing.assert_allclose(beat, f, rtol=0, atol=1e-9)
