"""Receiver arrays in the simulated chain: the far-field phase of every echo and attack at every receiver and slot,
the noise of each receiver, TDM activation per loop, batch invariance, and the single antenna left as it was."""
import math

import numpy as np
import pytest
import scipy.signal

from carav_stream.radar import physics, synth
from carav_stream.radar.activation import ActivationSource, balanced_rows, lowest_half
from carav_stream.radar.adc import adc_codes
from carav_stream.radar.arrays import hilbert, receiver_echoes
from carav_stream.radar.attackers import Observation, make_attacker, scene_attacker
from carav_stream.radar.noise import gaussian
from carav_stream.radar.scene_loader import scene_from_dict
from carav_stream.radar.synth import channel, echo_energy_per_chirp, observe, simulate_cycles, transmit
from tests.radar.conftest import SMALL

RX = (0.0, 0.5, 1.25, 1.5)          # receivers, wavelengths (not a uniform array: any positions)
TX = (0.0, 2.0)
THETA = 20.0
# what is left at a real receiver's beat bin of its negative-frequency image (beat_bins), which turns the other way;
# more for the attacks, which start or stop within the window (a gate's edge spreads the image over every bin)
I_ONLY_TOL = 0.01
I_ONLY_ATTACK_TOL = 0.06


def array_scene(iq=False, theta=THETA, rx=RX, tx=TX, schedule=(0, 1), **changes):
    """The small Table I radar (8 chirps of 256 samples) with an array, a car at 43 m and `theta` degrees."""
    target = {"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0, "azimuth_deg": theta}
    return scene_from_dict({**SMALL, "iq": iq, "rx_positions_wl": list(rx), "tx_positions_wl": list(tx),
                            "tdm_schedule": list(schedule), "targets": [target], **changes}, "array.toml")


def clean_echo(scene, fidelity):
    rho = np.ones((1, scene.n_chirps), bool)
    return simulate_cycles(scene, rho, np.random.default_rng(0), fidelity=fidelity, return_clean=True).clean_echo[0]


def beat_bins(x):
    """Hann-windowed DFT over the samples of (..., n_samples), and the bin of the strongest positive frequency. The
    window keeps a real signal's negative-frequency image, which turns the other way, out of its positive bins."""
    n = x.shape[-1]
    spectrum = np.fft.fft(x.astype(np.complex128) * np.hanning(n), axis=-1)
    ref = np.abs(spectrum.reshape(-1, n)[0, 1: n // 2])
    return spectrum, 1 + int(np.argmax(ref))


def wrapped(phase):
    return np.angle(np.exp(1j * np.asarray(phase)))


def psi(x_wl, theta_deg):
    return 2 * np.pi * x_wl * math.sin(math.radians(theta_deg))


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
@pytest.mark.parametrize("iq", [False, True])
def test_echo_phase_between_receivers_at_the_beat_bin_is_two_pi_dx_sin_theta(fidelity, iq):
    s = array_scene(iq=iq)
    x = clean_echo(s, fidelity)                                    # (n_rx, n_chirps, n_samples)
    assert x.shape == (4, 8, 256) and x.dtype == (np.complex64 if iq else np.float32)
    spectrum, b = beat_bins(x)
    tol = 1e-4 if iq else I_ONLY_TOL
    for r in range(1, 4):
        measured = np.angle(spectrum[r, :, b] * np.conj(spectrum[0, :, b]))     # every chirp (both slots)
        np.testing.assert_allclose(wrapped(measured - psi(RX[r], THETA)), 0.0, atol=tol)
    # the same amplitude on every receiver
    amplitude = np.abs(spectrum[:, :, b])
    np.testing.assert_allclose(amplitude, np.broadcast_to(amplitude[:1], amplitude.shape), rtol=2 * tol)


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
@pytest.mark.parametrize("iq", [False, True])
def test_tdm_slots_carry_their_transmitters_phase_three_axis_frames_for_one_receiver(fidelity, iq):
    # range rate 0: no Doppler progression, so chirp k and k-1 differ by their transmitters only
    for rx in (RX, (0.0,)):
        s = array_scene(iq=iq, rx=rx, targets=[{"range_m": 43.0, "velocity_kmh": 100.0, "rcs_m2": 100.0,
                                                "azimuth_deg": -35.0}])
        x = clean_echo(s, fidelity)
        assert x.shape == ((4, 8, 256) if len(rx) == 4 else (8, 256))
        spectrum, b = beat_bins(x)
        cells = spectrum[..., b].reshape(len(rx), 8)
        measured = np.angle(cells[:, 1::2] * np.conj(cells[:, 0::2]))           # slot 1 (tx 2.0) over slot 0 (tx 0)
        # at waveform fidelity a slot also holds a little of the chirp before's spill, which the other transmitter sent
        tol = (1e-4 if fidelity == "beat" else 1e-3) if iq else I_ONLY_TOL
        np.testing.assert_allclose(wrapped(measured - psi(TX[1] - TX[0], -35.0)), 0.0, atol=tol)


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
@pytest.mark.parametrize("iq", [False, True])
def test_the_echo_at_virtual_position_zero_is_the_single_antennas(fidelity, iq):
    """Receiver 0 in slot 0 (both at 0) gets the single antenna's echo of its chirp; its spill from the chirp before
    (waveform fidelity) left from the other transmitter and carries that one's phase."""
    s = array_scene(iq=iq)
    one = physics.echo_templates(array_scene(iq=iq, rx=(0.0,), tx=(0.0,), schedule=(0,)), fidelity)
    at_rx = receiver_echoes(s, fidelity)
    assert at_rx.main_sum.shape == (4, 8, 256)
    scale = np.abs(one.main_sum).max()
    np.testing.assert_allclose(at_rx.main_sum[0, 0::2], one.main_sum[0::2], atol=1e-6 * scale)
    if fidelity == "waveform":
        turn = np.exp(1j * psi(TX[1], THETA))       # slot 0's spill was sent by chirp k-1's transmitter, tx 1
        want = one.tail_sum[0::2] * turn if iq else None
        if iq:
            np.testing.assert_allclose(at_rx.tail_sum[0, 0::2], want, atol=1e-6 * scale)
        np.testing.assert_allclose(at_rx.tail_sum[0, 1::2], one.tail_sum[1::2], atol=1e-6 * scale)


def test_a_single_antenna_at_position_zero_gives_the_same_frames_bit_for_bit_whatever_the_azimuths():
    rho = ActivationSource("seeded", seed=2).next(3, 8)
    runs = []
    for theta in (0.0, 40.0):
        s = array_scene(theta=theta, rx=(0.0,), tx=(0.0,), schedule=(0,),
                        attackers=[{"kind": "random", "rarms": 2.0, "azimuth_deg": -theta}])
        runs.append(simulate_cycles(s, rho, np.random.default_rng(3), attacker=scene_attacker(s),
                                    rng_attack=np.random.default_rng(4)))
    assert runs[0].frames.shape == (3, 8, 256)
    assert runs[0].frames.tobytes() == runs[1].frames.tobytes()


@pytest.mark.parametrize("iq", [False, True])
def test_noise_is_independent_per_receiver_of_power_sigma_squared_drawn_in_c_order(iq):
    s = array_scene(iq=iq, targets=[], sigma_n=0.5)
    rho = np.ones((300, 8), bool)
    rx = channel(s, transmit(s, rho), np.random.default_rng(6))
    assert rx.shape == (300, 4, 8, 256)
    # C order over (cycle, receiver, chirp, sample): one block of the stream per cycle
    np.testing.assert_array_equal(rx, gaussian(np.random.default_rng(6), (300, 4, 8, 256), 0.5, iq))
    per_rx = np.moveaxis(rx, 1, 0).reshape(4, -1).astype(np.complex128)
    power = np.mean(np.abs(per_rx) ** 2, axis=1)
    np.testing.assert_allclose(power, 0.25, rtol=0.02)
    corr = np.abs(per_rx @ per_rx.conj().T) / (per_rx.shape[1] * 0.25)
    assert np.max(corr[~np.eye(4, dtype=bool)]) < 6 / math.sqrt(per_rx.shape[1])


def attack(kind, scene, theta, fidelity="beat", n=3):
    # replicas and the secondary antenna beating mid-band (bins 20 to 40 of 256), where little of a real signal's
    # negative-frequency image reaches the positive bins
    params = {"secondary_antenna": {"tx_power_w": 1e-6, "t_offset_s": 1e-6, "range_m": 60.0},
              "reactive": {"latency_s": 2e-8, "distance_m": 100.0}, "ghost": {"range_m": 100.0},
              "random": {}, "smart": {}}[kind]
    model = make_attacker(kind, scene, azimuth_deg=theta, **params)
    emission = np.ones((n, scene.n_chirps), bool)
    a, active = model.emit(n, 0, np.random.default_rng(9), Observation(emission, 0), fidelity=fidelity)
    assert active.all()
    return a


STEERED = [("random", "beat"), ("smart", "beat"), ("ghost", "beat"), ("reactive", "beat"), ("ghost", "waveform"),
           ("secondary_antenna", "waveform")]


@pytest.mark.parametrize("kind, fidelity", STEERED)
@pytest.mark.parametrize("iq", [False, True])
def test_attack_phase_between_receivers_is_two_pi_dx_sin_theta_one_way(kind, fidelity, iq):
    s = array_scene(iq=iq)
    a = attack(kind, s, -30.0, fidelity)
    assert a.shape == (3, 4, 8, 256) and a.dtype == (np.complex64 if iq else np.float32)
    spectrum, b = beat_bins(a)
    for r in range(1, 4):
        expect = psi(RX[r], -30.0)
        if kind in ("random", "smart") and not iq:
            # real samples turned through their discrete analytic signal: every positive bin turns by exactly psi
            plain = np.fft.fft(a.astype(np.float64), axis=-1)[..., 1:128]
            ratio = plain[:, r] / plain[:, 0]
            np.testing.assert_allclose(wrapped(np.angle(ratio) - expect), 0.0, atol=1e-3)
            continue
        measured = np.angle(spectrum[:, r, :, b] * np.conj(spectrum[:, 0, :, b]))
        np.testing.assert_allclose(wrapped(measured - expect), 0.0, atol=1e-4 if iq else I_ONLY_ATTACK_TOL)
    if not iq:      # every receiver gets Re{z e^(j psi_r)} of one analytic signal z: z from receivers 0 and 1
        re, p = a[:, 0].astype(np.float64), psi(np.array(RX), -30.0)
        im = (np.cos(p[1]) * re - a[:, 1]) / np.sin(p[1])
        for r in (2, 3):
            np.testing.assert_allclose(a[:, r], np.cos(p[r]) * re - np.sin(p[r]) * im, atol=1e-5 * np.abs(a).max())
    # one way: the transmitters do not matter
    other = array_scene(iq=iq, tx=(0.0, 3.7), schedule=(1, 0))
    np.testing.assert_array_equal(attack(kind, other, -30.0, fidelity), a)


@pytest.mark.parametrize("kind", ["random", "smart"])
@pytest.mark.parametrize("iq", [False, True])
def test_the_receiver_at_position_zero_gets_the_single_antennas_attack_bit_for_bit(kind, iq):
    a = attack(kind, array_scene(iq=iq), 25.0)
    one = attack(kind, array_scene(iq=iq, rx=(0.0,), tx=(0.0,), schedule=(0,)), 25.0)
    assert one.shape == (3, 8, 256) and a[:, 0].tobytes() == one.tobytes()


@pytest.mark.parametrize("kind", ["reactive", "ghost"])
def test_a_replica_is_silent_on_every_receiver_before_it_arrives(kind):
    """The replicas render their analytic signal from their physics: what arrives late stays absent before it on
    every receiver (the spill test looks there), where a transform over the window would spread it."""
    s = array_scene(iq=False)
    one = attack(kind, array_scene(iq=False, rx=(0.0,), tx=(0.0,), schedule=(0,)), 0.0)
    silent = one == 0
    assert silent[..., :50].all() and not silent.all()
    a = attack(kind, s, 35.0)
    assert all((a[:, r][silent] == 0).all() for r in range(4))


def test_the_hilbert_transform_turns_a_tone_a_quarter_period_and_is_scipys_analytic_signals_imaginary_part():
    n = np.arange(256)
    x = np.cos(2 * np.pi * 17 * n / 256 + 0.3)
    np.testing.assert_allclose(hilbert(x), np.sin(2 * np.pi * 17 * n / 256 + 0.3), atol=1e-12)
    for size in (255, 256):
        noise = np.random.default_rng(size).normal(size=(3, size))
        np.testing.assert_allclose(hilbert(noise), scipy.signal.hilbert(noise, axis=-1).imag, atol=1e-12)
        assert hilbert(noise.astype(np.float32)).dtype == np.float32


def test_an_attack_at_broadside_is_one_receiver_axis_that_broadcasts_and_composites_sum_their_azimuths():
    s = array_scene()
    flat = attack("smart", s, 0.0)
    assert flat.shape == (3, 1, 8, 256)
    two = array_scene(attackers=[{"kind": "random", "rarms": 1.0, "azimuth_deg": 10.0},
                                 {"kind": "smart", "rarms": 2.0, "azimuth_deg": -40.0}])
    both, _ = scene_attacker(two).emit(2, 0, np.random.default_rng(1))
    rng = np.random.default_rng(1)
    parts = [make_attacker("random", two, azimuth_deg=10.0, rarms=1.0),
             make_attacker("smart", two, azimuth_deg=-40.0, rarms=2.0)]
    want = np.zeros_like(both)
    for i in range(2):                                             # cycle by cycle, in list order, like the composite
        for p in parts:
            want[i] += p.emit(1, i, rng)[0][0]
    assert both.shape == (2, 4, 8, 256)
    np.testing.assert_array_equal(both, want)


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("kind", ["none", "random", "smart", "ramp", "ghost", "reactive"])
def test_array_batch_equals_stage_by_stage_and_chunked_bit_for_bit(monkeypatch, iq, kind):
    s = array_scene(iq=iq, adc_bits=10, rx=(0.0, 0.5, 1.25), tx=(0.0, 1.5), targets=[
        {"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0, "swerling": 1, "azimuth_deg": 12.0},
        {"range_m": 20.0, "rcs_m2": 10.0, "swerling": 2, "azimuth_deg": -50.0},
        {"range_m": 60.0, "rcs_m2": 50.0, "azimuth_deg": 3.0}])
    rho = ActivationSource("seeded", seed=2).next(5, s.n_chirps, s.n_slots)
    mk = lambda: make_attacker(kind, s, azimuth_deg=-20.0, **({"start_cycle": 1} if kind != "none" else {}))
    batch = simulate_cycles(s, rho, np.random.default_rng(7), attacker=mk(), rng_attack=np.random.default_rng(8))
    assert batch.frames.shape == (5, 3, 8, 256)
    rng_n, rng_a, att = np.random.default_rng(7), np.random.default_rng(8), mk()
    for i in range(5):
        tx = transmit(s, rho[i: i + 1], i, "beat")
        rx, active = att.apply(channel(s, tx, rng_n, i), i, rng_a, observe(tx), fidelity="beat")
        codes, clipped, _ = adc_codes(s, rx)
        assert codes.tobytes() == batch.codes[i: i + 1].tobytes()
        assert clipped[0] == batch.clipped[i] and active[0] == batch.attack_active[i]
    monkeypatch.setattr(synth, "CHUNK_BYTES", 2 * 3 * 8 * 256 * (8 if iq else 4))
    monkeypatch.setattr(synth, "CHANNEL_CHUNK_BYTES", 3 * 8 * 256 * (8 if iq else 4))
    chunked = simulate_cycles(s, rho, np.random.default_rng(7), attacker=mk(), rng_attack=np.random.default_rng(8))
    assert chunked.frames.tobytes() == batch.frames.tobytes()


def test_array_waveform_batch_equals_stage_by_stage_with_a_secondary_antenna():
    s = array_scene(iq=False)
    rho = ActivationSource("seeded", seed=2).next(3, s.n_chirps, s.n_slots)
    mk = lambda: make_attacker("secondary_antenna", s, azimuth_deg=30.0, tx_power_w=1e-6, t_chirp_s=7.5e-6)
    batch = simulate_cycles(s, rho, np.random.default_rng(1), attacker=mk())
    rng, att = np.random.default_rng(1), mk()
    for i in range(3):
        tx = transmit(s, rho[i: i + 1], i, "waveform")
        rx, _ = att.apply(channel(s, tx, rng, i), i, None, observe(tx), fidelity="waveform")
        assert adc_codes(s, rx)[0].tobytes() == batch.codes[i: i + 1].tobytes()


def test_the_adc_counts_a_cycles_clipped_samples_over_all_its_receivers():
    s = array_scene(adc_bits=8, adc_full_scale=1.0)
    rx = np.zeros(s.frame_shape(2), np.float32)
    rx[1, 0, 3, :5] = 2.0
    rx[1, 3, 7, 10:12] = -2.0
    rx[0, 2, 0, 0] = np.nan
    codes, clipped, nonfinite = adc_codes(s, rx)
    assert codes.shape == (2, 4, 8, 256) and clipped.tolist() == [0, 7] and nonfinite.tolist() == [1, 0]
    assert codes[1, 0, 3, 0] == 127 and codes[1, 3, 7, 10] == -128


def test_echo_energy_per_chirp_is_the_clean_echos_over_every_receiver():
    s = array_scene()
    rho = ActivationSource("seeded", seed=3).next(2, 8, 2)
    clean = simulate_cycles(s, rho, np.random.default_rng(0), return_clean=True).clean_echo.astype(np.float64)
    measured = np.sum(clean ** 2, axis=(1, 3))
    np.testing.assert_allclose(echo_energy_per_chirp(s, rho), measured, rtol=1e-4)


@pytest.mark.parametrize("kind", ["seeded", "secure", "lfsr"])
def test_tdm_activation_is_constant_within_each_loop_with_half_the_loops_active(kind):
    src = ActivationSource(kind, seed=None if kind == "secure" else 11)
    rho = src.next(50, 12, 3)
    loops = rho.reshape(50, 4, 3)
    assert (loops == loops[:, :, :1]).all() and (loops[:, :, 0].sum(axis=1) == 2).all()
    if kind == "seeded":     # one key per loop where a single transmitter draws one per chirp
        np.testing.assert_array_equal(loops[:, :, 0], ActivationSource("seeded", seed=11).next(50, 4))
        np.testing.assert_array_equal(balanced_rows(np.random.default_rng(2), 6, 12, 3),
                                      np.repeat(balanced_rows(np.random.default_rng(2), 6, 4), 3, axis=1))


def test_one_slot_activation_is_the_single_transmitters_draws():
    want = lowest_half(np.random.Generator(np.random.PCG64(11)).random((7, 16)))
    np.testing.assert_array_equal(ActivationSource("seeded", seed=11).next(7, 16, 1), want)
    np.testing.assert_array_equal(ActivationSource("seeded", seed=11).next(7, 16), want)


def test_an_activation_that_cannot_balance_its_loops_is_refused_naming_them():
    with pytest.raises(ValueError, match=r"the TDM loops \(12 chirps / 4 slots\) must be even"):
        ActivationSource("seeded", seed=1).next(1, 12, 4)
    with pytest.raises(ValueError, match="not a whole number of TDM loops of 5 slots"):
        ActivationSource("seeded", seed=1).next(1, 12, 5)
