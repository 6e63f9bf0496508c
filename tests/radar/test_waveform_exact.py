"""The waveform fidelity's shortcuts give the very bits of the expressions written out: the secondary antenna's cycle,
the modulo and the gated mixer product (the IF filter, scipy's oaconvolve, is the same on both sides).

The references below are the equations evaluated on the whole grid with numpy and scipy in the order the docstrings
write them; they take from the code only the grid itself (instants, reference phase, taps) and the amplitude.
"""
import math

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.core.units import C_MPS, KMH
from carav_stream.radar import physics
from carav_stream.radar.attackers import Observation, make_attacker
from carav_stream.radar.scene_loader import load_scene


def bits(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x).view(np.uint8)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(bits(a), bits(b))


def reference_filter(scene, y):
    g = physics.waveform_grid(scene)
    return scipy.signal.oaconvolve(y, g.taps.reshape((1,) * (y.ndim - 1) + (-1,)), mode="valid",
                                   axes=-1)[..., ::g.oversample]


def reference_cycles(att, cycles) -> list[np.ndarray]:
    """What the secondary antenna adds in each of ``cycles`` (consecutive, from a fresh attacker): its samples for
    the cycle's phase in its chirp period, where cycles whose phases round to the same femtosecond share the first
    one's (the attacker keeps up to nine)."""
    s, first, out = att.scene, {}, []
    for cycle in cycles:
        phase0 = (cycle * s.t_cycle_s - att.t_offset_s) % att.t_chirp_s
        key = round(phase0 * 1e15)
        if key not in first:
            if len(first) > 8:
                first.clear()
            first[key] = phase0
        out.append(reference_at(att, first[key]))
    return out


def reference_at(att, phase0: float) -> np.ndarray:
    """The secondary antenna's samples in a cycle that starts phase0 seconds into its chirp period, from its
    equations (SecondaryAntennaAttacker.mixed, carav_stream/radar/attackers/secondary_antenna.py)."""
    s = att.scene
    g = physics.waveform_grid(s)
    tau = (att.range_m + (att.velocity_mps - s.radar_speed_mps) * g.t_cycle_s) / C_MPS
    u = np.mod(g.t_cycle_s - tau + phase0, att.t_chirp_s)
    gate = u < att.t_sweep_s
    emitted = 2 * np.pi * att.f_offset_hz * u + np.pi * att.slope_hz_per_s * u * u
    phase = g.ref_phase + 2 * np.pi * s.fc_hz * tau - emitted
    y = np.exp(1j * phase) if s.iq else np.cos(phase)
    y *= att.amplitude()
    y *= gate
    a = np.zeros((s.n_chirps, s.n_samples), np.complex64 if s.iq else np.float32)
    a += reference_filter(s, y).astype(a.dtype)
    return a


INTERFERER = {"range_m": 60.0, "velocity_mps": -100 * KMH, "t_sweep_s": 7.33e-6, "t_chirp_s": 1.37 * 7.33e-6,
              "t_offset_s": 8.942e-6}
CASES = {
    "synchronised": {"tx_power_w": 2e-3},
    "slower slope, idle time": {**INTERFERER, "slope_hz_per_s": 0.5 * 20.46e12, "tx_power_w": 1e-3},
    "faster slope, offsets": {**INTERFERER, "slope_hz_per_s": 1.1 * 20.46e12, "f_offset_hz": 3e6,
                              "t_offset_s": -2.1e-6, "tx_power_w": 1e-3},
    "short sweep, negative offset": {"range_m": 12.0, "velocity_mps": 5.0, "t_sweep_s": 4e-6, "t_chirp_s": 6e-6,
                                     "f_offset_hz": -1e6, "slope_hz_per_s": 0.8 * 20.46e12, "tx_power_w": 1e-3},
}


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("case", sorted(CASES))
def test_secondary_antenna_cycles_are_their_equations_bit_for_bit(small_scene, iq, case):
    s = small_scene(iq=iq)
    att = make_attacker("secondary_antenna", s, **CASES[case])
    cycle0, n = 5, 4
    emission = np.ones((n, s.n_chirps), dtype=bool)
    a, active = att.emit(n, cycle0, None, Observation(emission, cycle0), fidelity="waveform")
    assert active.all()
    for i, ref in enumerate(reference_cycles(att, range(cycle0, cycle0 + n))):
        assert same_bits(a[i], ref), f"cycle {cycle0 + i}"


@pytest.mark.parametrize("iq", [False, True])
def test_secondary_antenna_on_the_table1_grid_is_its_equations_bit_for_bit(iq):
    s = load_scene("table1", {"iq": iq})                         # 64 chirps: five filter blocks a row
    att = make_attacker("secondary_antenna", s, **CASES["faster slope, offsets"])
    a, _ = att.emit(2, 40, None, Observation(np.ones((2, s.n_chirps), dtype=bool), 40), fidelity="waveform")
    for i, ref in enumerate(reference_cycles(att, [40, 41])):
        assert same_bits(a[i], ref)


def test_secondary_antenna_mixer_output_is_the_product_written_out(small_scene):
    s = small_scene()
    att = make_attacker("secondary_antenna", s, **CASES["faster slope, offsets"])
    g = physics.waveform_grid(s)
    phase0 = 3.3e-6
    tau = (att.range_m + (att.velocity_mps - s.radar_speed_mps) * g.t_cycle_s) / C_MPS
    u = np.mod(g.t_cycle_s - tau + phase0, att.t_chirp_s)
    phase = (g.ref_phase + 2 * np.pi * s.fc_hz * tau
             - (2 * np.pi * att.f_offset_hz * u + np.pi * att.slope_hz_per_s * u * u))
    gate = u < att.t_sweep_s
    assert 0 < gate.mean() < 1
    y = att.mixed(phase0)
    assert np.array_equal(y, np.cos(phase) * att.amplitude() * gate)     # off the gate: 0 for cos A 0 (= +-0)
    assert same_bits(y[gate], np.cos(phase[gate]) * att.amplitude())


def test_an_infinite_amplitude_spreads_nan_as_the_product_written_out(small_scene):
    s = small_scene()
    att = make_attacker("secondary_antenna", s, **{**CASES["synchronised"], "tx_power_w": 1e300, "tx_gain_db": 200.0})
    assert math.isinf(att.amplitude())
    with np.errstate(invalid="ignore"):
        a, _ = att.emit(1, 0, None, Observation(np.ones((1, s.n_chirps), dtype=bool), 0), fidelity="waveform")
        ref = reference_at(att, 0.0)
    assert np.isnan(ref).all() and np.isnan(a[0]).all()


PERIODS = [7.33e-6, 1.37 * 7.33e-6, 1e-5, 2.0 ** -17, 1.999 * 2.0 ** -17, 3e-9, 1.0, 123.4]


@pytest.mark.parametrize("period", PERIODS)
def test_wrap_is_numpy_mod_bit_for_bit(period):
    rng = np.random.default_rng(11)
    k = rng.integers(-3, 70, 20000).astype(float)
    near = k * period + rng.integers(-3, 4, k.size) * np.spacing(k * period)   # around whole periods
    spread = rng.uniform(-3 * period, 70 * period, 20000)
    edge = np.array([0.0, -0.0, period, -period, np.nextafter(period, 0), np.nextafter(period, 1), 1e-300, -1e-300,
                     2 ** 20 * period, 2 ** 21 * period, np.nan])
    x = np.concatenate([near, spread, edge])
    assert same_bits(physics.wrap_s(x, period), np.mod(x, period))


@settings(max_examples=300)
@given(period=st.floats(1e-12, 1e6), k=st.integers(-10, 2 ** 22), frac=st.floats(-1.0, 2.0), ulps=st.integers(-4, 4))
def test_wrap_is_numpy_mod_for_any_period_and_time(period, k, frac, ulps):
    base = k * period
    x = np.array([base, base + frac * period, np.nextafter(base, math.inf), np.nextafter(base, -math.inf),
                  base + ulps * np.spacing(base), frac * period])
    assert same_bits(physics.wrap_s(x, period), np.mod(x, period))


@pytest.mark.parametrize("iq", [False, True])
def test_tone_is_the_gated_product_written_out(small_scene, iq):
    s = small_scene(iq=iq)
    rng = np.random.default_rng(5)
    phase = rng.uniform(-2e5, 2e5, (8, 1000))
    gate = rng.random(phase.shape) < 0.6
    full = (np.exp(1j * phase) if iq else np.cos(phase)) * 2.5e-3 * gate
    y = physics.tone(s, phase, 2.5e-3, gate)
    assert np.array_equal(y, full) and same_bits(y[gate], full[gate])
    phase[3, 7] = np.nan                                          # a NaN anywhere spreads as in the product
    with np.errstate(invalid="ignore"):
        full = (np.exp(1j * phase) if iq else np.cos(phase)) * 2.5e-3 * gate
        y = physics.tone(s, phase, 2.5e-3, gate)
    assert same_bits(y, full)
