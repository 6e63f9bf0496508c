"""CRLB: textbook closed forms, and an independent Monte Carlo of the exact ML (scipy optimiser)."""
import numpy as np
import pytest
import scipy.optimize

from carav_stream.estimate.crlb import fmcw_crlb, slow_time_spread, tone_frequency_crlb
from carav_stream.estimate.matlab_reference import fmcw_example_geometry as table1_geometry


def test_uniform_bound_equals_textbook_formula():
    snr, n = 10.0, 128
    textbook = 6.0 / ((2 * np.pi) ** 2 * snr * n * (n * n - 1))
    assert tone_frequency_crlb(snr, n) == pytest.approx(textbook, rel=1e-12)
    assert tone_frequency_crlb(snr, times=np.arange(n)) == pytest.approx(textbook, rel=1e-12)
    assert tone_frequency_crlb(snr, n, iq=False) == pytest.approx(2 * textbook, rel=1e-12)


def test_sparse_slow_time_spread_is_sum_of_squared_deviations():
    rho = np.array([[True, False, True, True, False, False, False, True]])
    t = np.flatnonzero(rho[0]).astype(float)
    assert slow_time_spread(rho)[0] == pytest.approx(np.sum((t - t.mean()) ** 2))


def test_fmcw_crlb_integrates_over_active_chirps_only():
    g = table1_geometry()
    rho_all = np.ones(64, bool)
    rho_half = rho_all.copy()
    rho_half[1::2] = False
    a, h = fmcw_crlb(g, 0.0, rho_all), fmcw_crlb(g, 0.0, rho_half)
    assert h["beat_hz"] / a["beat_hz"] == pytest.approx(np.sqrt(2.0), rel=1e-9)
    assert a["snr_integrated_db"] == pytest.approx(10 * np.log10(64))


def test_monte_carlo_ml_frequency_variance_approaches_bound():
    rng = np.random.default_rng(11)
    n, snr, f0 = 32, 100.0, 0.2137
    t = np.arange(n)
    est = []
    for _ in range(300):
        y = np.exp(2j * np.pi * (f0 * t + rng.random())) + (rng.standard_normal(n) + 1j * rng.standard_normal(n)) \
            * np.sqrt(0.5 / snr)
        res = scipy.optimize.minimize_scalar(lambda f: -abs(np.sum(y * np.exp(-2j * np.pi * f * t))) ** 2,
                                             bounds=(f0 - 0.5 / n, f0 + 0.5 / n), method="bounded",
                                             options={"xatol": 1e-10})
        est.append(res.x)
    ratio = np.mean((np.array(est) - f0) ** 2) / tone_frequency_crlb(snr, n)
    assert 0.75 < ratio < 1.3


def test_a_late_echo_is_bounded_by_the_samples_that_hold_it():
    from carav_stream.estimate.geometry import Geometry
    from carav_stream.radar.scene_loader import load_scene
    g = Geometry.from_scene(load_scene("table1"))                  # the car's echo from sample 28 of 1080 on
    rho = np.ones((1, 64), bool)
    late = fmcw_crlb(g, 2.2, rho, range_m=43.0, couple=False)["beat_hz"]
    held = np.sqrt(tone_frequency_crlb(10 ** 0.22 * 64, 1080 - 28, iq=False)) * g.fs_hz
    assert late == pytest.approx(held, rel=1e-12)
    assert late == pytest.approx(fmcw_crlb(g, 2.2, rho, couple=False)["beat_hz"] * (1080 / 1052) ** 1.5, rel=1e-3)
    # an echo there before the window starts fills it
    assert fmcw_crlb(g, 2.2, rho, range_m=5.0)["range_m"] == pytest.approx(fmcw_crlb(g, 2.2, rho)["range_m"])
