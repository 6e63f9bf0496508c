"""Opt-in detectors: exact spectral threshold, ghost below D0 caught, latency and CUSUM behaviour, errors."""
from __future__ import annotations

import numpy as np
import pytest

from carav_stream.detect.detector import detect
from carav_stream.detect.opt_in import (
    calibrate_threshold,
    cusum_silent_power,
    cusum_threshold,
    latency_statistic,
    silent_power_z,
    spectral_silent_test,
    spectral_threshold,
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


def test_latency_statistic_grows_when_energy_starts_late_in_active_chirps():
    rng = np.random.default_rng(3)
    rho = balanced_rows(rng, 50, 8)
    x = rng.standard_normal((50, 8, 128))
    base = latency_statistic(x, rho, 16)
    late = x.copy()
    late[..., 40:] += np.where(rho[..., None], 2.0 * rng.standard_normal((50, 8, 88)), 0)
    assert np.median(latency_statistic(late, rho, 16)) > 3 * np.median(base)


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
