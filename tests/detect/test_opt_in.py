"""Opt-in detectors: exact spectral threshold, ghost below D0 caught, latency and CUSUM behaviour, errors."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.fft

from carav_stream.detect.detector import detect
from carav_stream.detect.opt_in import (
    calibrate_threshold,
    cusum_silent_power,
    cusum_threshold,
    integrated_silent_test,
    integrated_threshold,
    silent_power_z,
    spectral_silent_test,
    spectral_threshold,
    spill_test,
    spill_tests,
)
from carav_stream.detect.stats import clopper_pearson
from carav_stream.radar.activation import balanced_rows


@pytest.mark.parametrize("iq", [False, True])
def test_spectral_test_false_alarm_rate_matches_exact_threshold(iq):
    rng = np.random.default_rng(1)
    n, n_r, n_s = 4000, 8, 64
    rho = balanced_rows(rng, n, n_r)
    x = rng.standard_normal((n, n_r, n_s))
    if iq:
        x = (x + 1j * rng.standard_normal((n, n_r, n_s))) / np.sqrt(2)
    res = spectral_silent_test(x, rho, 1.0, pf=0.05)
    lo, hi = clopper_pearson(int(res.alarm.sum()), n, 0.999)
    assert lo <= 0.05 <= hi


def test_spectral_threshold_is_exact_max_of_exponentials():
    t = spectral_threshold(1e-6, 1000)
    assert 1 - (1 - np.exp(-t)) ** 1000 == pytest.approx(1e-6, rel=1e-9)


def test_spectral_test_catches_coherent_ghost_that_d0_misses():
    rng = np.random.default_rng(2)
    n, n_r, n_s = 200, 16, 512
    rho = balanced_rows(rng, n, n_r)
    ghost = 0.5 * np.sqrt(2) * np.cos(2 * np.pi * 37.3 / n_s * np.arange(n_s))   # RMS 0.5 sigma_n, every chirp
    x = rng.standard_normal((n, n_r, n_s)) + ghost
    assert not detect(x, rho, 1.0).alarm.any()                     # sqrt(1 + 0.25) = 1.12 < 1.5
    res = spectral_silent_test(x, rho, 1.0, pf=1e-6)
    assert res.alarm.all() and np.all(np.abs(res.peak_bin - 36) <= 1)   # rfft bin 37 minus the dropped DC


@pytest.mark.slow
@pytest.mark.parametrize("iq", [False, True])
def test_integrated_test_false_alarm_rate_matches_exact_threshold(iq):
    rng = np.random.default_rng(3)
    n, n_r, n_s = 4000, 16, 64
    rho = balanced_rows(rng, n, n_r)
    x = rng.standard_normal((n, n_r, n_s))
    if iq:
        x = (x + 1j * rng.standard_normal((n, n_r, n_s))) / np.sqrt(2)
    res = integrated_silent_test(x, rho, 1.0, pf=0.05)
    assert res.n_bins_tested == (n_s if iq else n_s // 2 - 1)
    lo, hi = clopper_pearson(int(res.alarm.sum()), n, 0.999)
    assert lo <= 0.05 <= hi


def test_integrated_threshold_is_the_chi_square_law_of_summed_bins():
    """A sum of M Exp(1) is chi2(2M) / 2: an independent route to the same threshold."""
    from scipy import stats

    t = integrated_threshold(1e-6, 500, 32)
    per_bin = 1 - (1 - 1e-6) ** (1 / 500)
    assert t == pytest.approx(stats.chi2.isf(per_bin, 64) / 2, rel=1e-9)
    assert integrated_threshold(1e-6, 500, 1) == pytest.approx(spectral_threshold(1e-6, 500), rel=1e-9)


def test_integration_catches_a_ghost_the_single_chirp_test_misses():
    rng = np.random.default_rng(4)
    n, n_r, n_s = 200, 64, 256
    rho = balanced_rows(rng, n, n_r)
    # peak bin power N_s a^2 / 4 / sigma^2 = 5.1 per chirp (7 dB), far under the single-chirp threshold (~21)
    ghost = 0.2 * np.sqrt(2) * np.cos(2 * np.pi * 41.0 / n_s * np.arange(n_s))   # RMS 0.2 sigma_n
    x = rng.standard_normal((n, n_r, n_s)) + ghost
    assert spectral_silent_test(x, rho, 1.0, pf=1e-6).alarm.mean() < 0.1
    res = integrated_silent_test(x, rho, 1.0, pf=1e-6)
    assert res.alarm.all() and np.all(res.peak_bin == 40)            # rfft bin 41 minus the dropped DC
    assert not integrated_silent_test(rng.standard_normal((n, n_r, n_s)), rho, 1.0, pf=1e-6).alarm.any()


@pytest.mark.parametrize("iq", [False, True])
def test_spill_test_false_alarm_rate_matches_its_exact_threshold(iq):
    rng = np.random.default_rng(5)
    n, n_r, n_s = 4000, 8, 96
    rho = balanced_rows(rng, n, n_r)
    x = rng.standard_normal((n, n_r, n_s))
    if iq:
        x = (x + 1j * rng.standard_normal((n, n_r, n_s))) / np.sqrt(2)
    res = spill_test(x, rho, 1.0, 40, pf=0.05)
    lo, hi = clopper_pearson(int(res.alarm.sum()), n, 0.999)
    assert lo <= 0.05 <= hi
    assert np.all(res.n_slots == np.sum(rho[:, :-1] & ~rho[:, 1:], axis=1))
    # energy before the window is not looked at; energy after it, in a silent slot after an active one, is
    late = x.copy()
    late[:, :, :40] += 50.0
    assert np.array_equal(spill_test(late, rho, 1.0, 40, pf=0.05).alarm, res.alarm)
    tone = 2.0 * np.cos(2 * np.pi * 0.2 * np.arange(n_s - 40))       # 56 x noise in its bin per slot
    after = rho[:, :-1] & ~rho[:, 1:]
    late = x.copy()
    late[:, 1:, 40:] += np.where(after[..., None], tone, 0)
    assert spill_test(late, rho, 1.0, 40, pf=1e-6).alarm[res.n_slots > 0].all()


def test_spill_test_batches_equal_single_cycles():
    rng = np.random.default_rng(6)
    rho = balanced_rows(rng, 7, 8)
    x = rng.standard_normal((7, 8, 64)).astype(np.float32)
    res = spill_test(x, rho, 1.0, 20)
    for i in range(7):
        one = spill_test(x[i: i + 1], rho[i: i + 1], 1.0, 20)
        assert one.stat.tobytes() == res.stat[i: i + 1].tobytes()


@pytest.mark.parametrize("iq, n_rx", [(False, 1), (True, 1), (False, 4), (True, 3)])
def test_the_spill_test_transforms_only_its_used_slots_and_gives_the_sum_over_every_chirp_to_the_bit(iq, n_rx):
    """Its definition written out: every chirp's window transformed, the chirps that are no used slot set to zero, the
    sum over all the chirps of a cycle and its receivers; at two false-alarm rates from one pass, each as its own
    spill_test gives it."""
    rng = np.random.default_rng(11 + n_rx)
    n, n_c, n_s, first, sigma = 9, 16, 100, 37, 1.7
    rho = balanced_rows(rng, n, n_c)
    x = rng.standard_normal((n, n_rx, n_c, n_s)).astype(np.float32)
    if iq:
        x = (x + 1j * rng.standard_normal(x.shape)).astype(np.complex64)
    x[2, ..., first + 5] += 40.0                        # a loud spill in one cycle's every slot
    spec = (scipy.fft.fft if iq else scipy.fft.rfft)(x[..., first:], axis=-1)      # in float32, as the test does
    spec = spec if iq else spec[..., 1: (n_s - first - 1) // 2 + 1]
    power = (spec.real.astype(np.float64) ** 2 + spec.imag.astype(np.float64) ** 2) / ((n_s - first) * sigma ** 2)
    used = np.zeros_like(rho)
    used[:, 1:] = rho[:, :-1] & ~rho[:, 1:]
    peak = np.sum(np.where(used[:, None, :, None], power, 0.0), axis=(1, 2)).max(axis=1)
    results = spill_tests(x if n_rx > 1 else x[:, 0], rho, sigma, first, [0.05, 1e-6], receivers=n_rx > 1)
    for pf, res in zip([0.05, 1e-6], results):
        np.testing.assert_allclose(res.stat * res.threshold, peak, rtol=1e-12)
        alone = spill_test(x if n_rx > 1 else x[:, 0], rho, sigma, first, pf=pf, receivers=n_rx > 1)
        assert res.stat.tobytes() == alone.stat.tobytes() and np.array_equal(res.alarm, alone.alarm)
        assert np.array_equal(res.n_slots, used.sum(axis=1)) and res.alarm[2]


def test_spill_test_names_a_window_outside_the_chirp():
    with pytest.raises(ValueError, match=r"first_sample: must be in 0..60, got 70"):
        spill_test(np.zeros((1, 8, 64)), np.tile([True, False], 4), 1.0, 70)


def test_calibrate_threshold_refuses_too_few_cycles():
    with pytest.raises(ValueError, match=r"100 attack-free cycles are too few for pf = 0.001"):
        calibrate_threshold(np.ones(100), 1e-3)


def test_cusum_detects_slow_ramp_long_before_per_cycle_d0():
    rng = np.random.default_rng(4)
    n_cycles, n_r, n_s = 400, 16, 64
    rho = balanced_rows(rng, n_cycles, n_r)
    rarms = np.linspace(0.0, 1.5, n_cycles)
    x = rng.standard_normal((n_cycles, n_r, n_s)) * np.sqrt(1 + rarms ** 2)[:, None, None]
    det = detect(x, rho, 1.0)
    z = silent_power_z(det.rms, rho, 1.0, n_s)
    s, alarm = cusum_silent_power(z, k=0.5, h=cusum_threshold(1e6))
    first_cusum = int(np.argmax(alarm))
    first_d0 = int(np.argmax(det.alarm))
    assert alarm.any() and first_cusum < first_d0 / 2


def test_silent_power_z_is_standard_normal_under_noise():
    rng = np.random.default_rng(5)
    rho = balanced_rows(rng, 20_000, 8)
    x = rng.standard_normal((20_000, 8, 32))
    z = silent_power_z(detect(x, rho, 1.0).rms, rho, 1.0, 32)
    assert abs(z.mean()) < 0.03 and z.std() == pytest.approx(1.0, abs=0.03)


def test_coherent_silent_test_keeps_its_pf_and_integrates_a_ghost_coherently():
    from carav_stream.detect.opt_in import coherent_silent_test

    rng = np.random.default_rng(6)
    n, n_r, n_s = 300, 64, 256
    rho = balanced_rows(rng, n, n_r)
    res = coherent_silent_test(rng.standard_normal((n, n_r, n_s)), rho, 1.0, pf=0.05)
    lo, hi = clopper_pearson(int(res.alarm.sum()), n, 0.999)
    assert lo <= 0.05 and res.n_bins_tested == n_r * (n_s // 2 - 1)      # the union bound: PF <= pf
    assert res.alarm.mean() > 0.02                                      # and not far below it
    # a ghost in every chirp period with a steady Doppler phase (on a Doppler bin), 3 dB per silent chirp in its
    # range bin: the 32 silent chirps add coherently to 2 x 32 x 2/3 (Hann) = 42.7 against the 22.8 threshold
    t, m = np.arange(n_s), np.arange(n_r)[:, None]
    a = np.sqrt(8 / n_s)                                                # |X|^2 / N_s = a^2 N_s / 4 = 2 (3 dB)
    x = rng.standard_normal((n, n_r, n_s)) + a * np.cos(2 * np.pi * (41.0 / n_s * t + 0.125 * m))
    res = coherent_silent_test(x, rho, 1.0, pf=1e-6)
    assert res.alarm.mean() > 0.95
    assert np.all(res.peak_bin[res.alarm] == 8 * (n_s // 2 - 1) + 40)    # Doppler bin 8, range bin 41 - DC
