"""Opt-in detectors on a receiver array: exact false-alarm rates over n_rx receivers, a ghost seen better on four
receivers than on one, one receiver unchanged."""
from __future__ import annotations

import numpy as np
import pytest

from carav_stream.detect.detector import chirp_rms
from carav_stream.detect.opt_in import (
    coherent_silent_test,
    integrated_silent_test,
    silent_power_z,
    spectral_silent_test,
    spill_test,
)
from carav_stream.detect.stats import clopper_pearson
from carav_stream.radar.activation import balanced_rows

N_RX, N_CHIRPS, N_S = 4, 8, 32
FIRST = 8                                   # the spill test's window: samples 8..31


def _spill(x, rho, sigma_n, *, pf, receivers=False):
    return spill_test(x, rho, sigma_n, FIRST, pf=pf, receivers=receivers)


TESTS = {"spectral": spectral_silent_test, "integrated": integrated_silent_test,
         "coherent": coherent_silent_test, "spill": _spill}


def _noise(rng, shape, iq: bool) -> np.ndarray:
    """White Gaussian noise of unit power per sample (float32 I only, complex64 I/Q)."""
    if not iq:
        return rng.standard_normal(shape).astype(np.float32)
    return ((rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / np.sqrt(2)).astype(np.complex64)


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("name", list(TESTS))
def test_false_alarm_rate_on_four_receivers_is_the_design_pf(name, iq):
    # independent seeds per test and sample kind; 1e-2 per cycle over 2000 cycles: 20 expected alarms. A threshold
    # of one receiver's law (Gamma(M) instead of Gamma(n_rx M)) would alarm in nearly every cycle.
    seed = 100 + 2 * list(TESTS).index(name) + iq
    rng = np.random.default_rng(seed)
    n, pf = 2000, 1e-2
    rho = balanced_rows(rng, n, N_CHIRPS)
    res = TESTS[name](_noise(rng, (n, N_RX, N_CHIRPS, N_S), iq), rho, 1.0, pf=pf, receivers=True)
    assert res.n_rx == N_RX and res.alarm.shape == (n,)
    lo, hi = clopper_pearson(int(res.alarm.sum()), n, 0.999)
    if name == "coherent":                  # the union bound: at most pf, and not far below it
        assert lo <= pf and hi >= pf / 4
    else:                                   # exact
        assert lo <= pf <= hi


def _ghost(n: int, n_rx: int, iq: bool, amp: float, rng) -> np.ndarray:
    """One attacker's tone in every chirp period (a steady Doppler phase: Doppler bin 1 of 8), on every receiver
    with the same power and its steering phase from 20 degrees (receivers half a wavelength apart): RMS amp for I/Q,
    amp sqrt(2) for I only (a real tone splits its power between +f and -f: the same power in the bin tested)."""
    t, m = np.arange(N_S), np.arange(N_CHIRPS)[:, None]
    steer = 2 * np.pi * 0.5 * np.arange(n_rx) * np.sin(np.radians(20.0))
    phase = 2 * np.pi * (9.0 / N_S * t + m / N_CHIRPS) + steer[:, None, None] + rng.uniform(0, 2 * np.pi, (n, 1, 1, 1))
    tone = amp * np.exp(1j * phase) if iq else 2 * amp * np.cos(phase)
    return tone.astype(np.complex64 if iq else np.float32)


AMP = {"spectral": 0.4, "integrated": 0.27, "coherent": 0.3, "spill": 0.45}


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("name", list(TESTS))
def test_a_ghost_on_four_receivers_is_caught_more_often_than_on_one(name, iq):
    # the same cycles: receiver 0 alone against all four, each at its exact design for pf 1e-3
    rng = np.random.default_rng(300 + 2 * list(TESTS).index(name) + iq)
    n = 300
    rho = balanced_rows(rng, n, N_CHIRPS)
    x = _noise(rng, (n, N_RX, N_CHIRPS, N_S), iq) + _ghost(n, N_RX, iq, AMP[name], rng)
    one = TESTS[name](x[:, 0], rho, 1.0, pf=1e-3)
    four = TESTS[name](x, rho, 1.0, pf=1e-3, receivers=True)
    assert one.alarm.mean() < 0.5 and four.alarm.mean() > one.alarm.mean() + 0.4


@pytest.mark.parametrize("name", list(TESTS))
def test_one_receiver_on_a_receiver_axis_is_the_one_receiver_test_bit_for_bit(name):
    rng = np.random.default_rng(5)
    rho = balanced_rows(rng, 20, N_CHIRPS)
    x = _noise(rng, (20, N_CHIRPS, N_S), True) + _ghost(20, 1, True, 0.3, rng)[:, 0]
    a = TESTS[name](x, rho, 1.1, pf=1e-3)
    b = TESTS[name](x[:, None], rho, 1.1, pf=1e-3, receivers=True)
    for field in ("stat", "alarm", "threshold", "n_rx"):
        assert np.array_equal(getattr(a, field), getattr(b, field))
    assert a.n_rx == 1


def test_one_cycle_of_an_array_and_a_batch_of_one_agree():
    rng = np.random.default_rng(6)
    rho = balanced_rows(rng, 1, N_CHIRPS)
    x = _noise(rng, (1, N_RX, N_CHIRPS, N_S), False)
    for test in TESTS.values():
        assert np.array_equal(test(x[0], rho[0], 1.0, pf=1e-3, receivers=True).stat,
                              test(x, rho, 1.0, pf=1e-3, receivers=True).stat)


@pytest.mark.parametrize("name", list(TESTS))
def test_an_array_without_receivers_true_is_refused_by_name(name):
    x = np.zeros((2, N_RX, N_CHIRPS, N_S), np.float32)
    with pytest.raises(ValueError, match="receivers=True"):
        TESTS[name](x, balanced_rows(np.random.default_rng(0), 2, N_CHIRPS), 1.0, pf=1e-3)


@pytest.mark.parametrize("iq", [False, True])
def test_silent_power_z_over_four_receivers_is_standard_normal_with_n_rx(iq):
    rng = np.random.default_rng(9 + iq)
    n = 8000
    rho = balanced_rows(rng, n, N_CHIRPS)
    rms = chirp_rms(_noise(rng, (n, N_RX, N_CHIRPS, 16), iq), receivers=True)
    nu = 32 if iq else 16
    z = silent_power_z(rms, rho, 1.0, nu, n_rx=N_RX)
    assert abs(z.mean()) < 0.05 and z.std() == pytest.approx(1.0, abs=0.04)
    # one receiver's degrees of freedom understate the combined power's concentration: z spreads half as wide
    assert silent_power_z(rms, rho, 1.0, nu).std() == pytest.approx(0.5, abs=0.03)
    with pytest.raises(ValueError, match="n_rx"):
        silent_power_z(rms, rho, 1.0, nu, n_rx=0)
