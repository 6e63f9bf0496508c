"""The attacker's direction from the silent slots (attacker_direction): an attacker at 30 degrees whose RMS is 3 times
the echo's (the paper's RARMS 3: attack RMS over the echo's) found within 2 degrees on attacked cycles of the awr1642
layout, NaN with its reason on clean ones; an I-only receiver's sign ambiguity for an attack on both sides of the
oscillator; detections in the attacker's direction flagged."""
import numpy as np
import pytest

from carav_stream.estimate.attacker_direction import (
    ESTIMATED,
    MIRRORED,
    NO_ATTACK,
    NO_SILENT,
    AttackerDirection,
    attacker_direction,
    matches_attacker,
)
from carav_stream.radar.scene_loader import load_scene
from tests.estimate import mimo_tones as mt

RX = mt.AWR1642["rx"]
N_CYCLES, N_CHIRPS, N_SAMPLES = 24, 128, 256


def _attacked_frames(iq, sides, seed, azimuth_deg=30.0):
    """Frames of an echo at 0 degrees on the active loops (balanced: 32 of 64) and an attack on every chirp of the
    even cycles at azimuth_deg, E|attack|^2 = 9 a^2 (so its RMS at the receiver is 3 times the echo's, I/Q or I-only):
    white on both sides of the oscillator (sides 2), or on the positive beats only (sides 1)."""
    rng = np.random.default_rng(seed)
    loops = np.zeros((N_CYCLES, 64), bool)
    for row in loops:
        row[rng.permutation(64)[:32]] = True
    rho = np.repeat(loops, 2, axis=1)
    attacked = np.arange(N_CYCLES) % 2 == 0
    shape = (N_CYCLES, N_CHIRPS, N_SAMPLES)
    s = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * np.sqrt(9 / 2)
    if sides == 1:
        spec = np.fft.fft(s, axis=-1)
        spec[..., N_SAMPLES // 2:] = 0
        spec[..., 0] = 0
        s = np.fft.ifft(spec, axis=-1) * np.sqrt(2)
    s *= attacked[:, None, None]
    x = mt.frames(rng, N_CYCLES, [mt.Tone(0.1625, 0.15, 0.0)], snr_db=load_scene("awr1642").snr_db(0), iq=iq,
                  rho=rho, attack=s, attack_deg=azimuth_deg)
    return x, rho, attacked


def _echo_and_attack_rms(x, rho, attacked):
    """RMS of the echo (active chirps of clean cycles) and of the attack (silent chirps of attacked ones), noise
    included in both (27 dB below the echo)."""
    power = np.abs(x.astype(complex)) ** 2

    def rms(cycles, chirps):
        mask = np.broadcast_to((cycles[:, None] & chirps)[:, None, :, None], x.shape)
        return np.sqrt(power[mask].mean())
    return rms(~attacked, rho), rms(attacked, ~rho)


@pytest.mark.parametrize("iq,sides", [(True, 2), (False, 1)])
def test_the_attackers_azimuth_is_found_on_attacked_cycles_and_nan_on_clean_ones(iq, sides):
    x, rho, attacked = _attacked_frames(iq, sides, seed=81 + iq)
    echo_rms, attack_rms = _echo_and_attack_rms(x, rho, attacked)
    assert attack_rms / echo_rms == pytest.approx(3.0, rel=0.05)
    d = attacker_direction(x, rho, RX)
    assert np.all(d.reason[attacked] == ESTIMATED)
    assert np.abs(d.azimuth_deg[attacked] - 30.0).max() < 2.0
    assert np.all(d.inr_db[attacked] == pytest.approx(10 * np.log10(attack_rms ** 2 / mt.noise_sigma(
        load_scene("awr1642").snr_db(0), iq=iq) ** 2), abs=0.5))
    assert np.all(np.isnan(d.azimuth_deg[~attacked])) and np.all(d.reason[~attacked] == NO_ATTACK)
    assert np.all(np.isnan(d.azimuth_std_deg[~attacked])) and np.all(d.n_sources[~attacked] == 0)


def test_an_i_only_receiver_cannot_tell_the_sign_of_a_white_attacks_azimuth_and_says_so():
    x, rho, attacked = _attacked_frames(False, 2, seed=91, azimuth_deg=-30.0)
    d = attacker_direction(x, rho, RX)
    assert np.all(d.reason[attacked] == MIRRORED) and np.all(d.n_sources[attacked] == 2)
    assert np.abs(d.azimuth_deg[attacked] - 30.0).max() < 2.0                  # |azimuth|
    one, rho1, attacked1 = _attacked_frames(False, 1, seed=92, azimuth_deg=-30.0)
    assert np.abs(attacker_direction(one, rho1, RX).azimuth_deg[attacked1] + 30.0).max() < 2.0


def test_a_cycle_without_silent_slots_has_no_direction_and_its_reason():
    x, rho, _ = _attacked_frames(True, 2, seed=93)
    rho[0] = True
    d = attacker_direction(x, rho, RX)
    assert d.reason[0] == NO_SILENT and np.isnan(d.azimuth_deg[0]) and d.reason[2] == ESTIMATED
    with pytest.raises(ValueError, match="n_rx = 4 >= 2"):
        attacker_direction(x[:, :1], rho, RX)


def test_detections_within_both_deviations_of_the_attacker_are_flagged():
    att = AttackerDirection(azimuth_deg=np.array([30.0, np.nan, 30.0]), azimuth_std_deg=np.array([0.3, np.nan, 0.3]),
                            inr_db=np.array([30.0, np.nan, 30.0]), eigen_ratio=np.array([1e3, np.nan, 1e3]),
                            n_sources=np.array([1, 0, 2]), reason=np.array([ESTIMATED, NO_ATTACK, MIRRORED]))
    az = np.array([[30.9, 32.0, -30.0], [30.0, 0.0, np.nan], [-30.5, 31.0, 10.0]])
    std = np.full((3, 3), 0.4)
    flag = matches_attacker(az, std, att)                                    # tolerance 3 x 0.5 = 1.5 degrees
    assert flag.tolist() == [[True, False, False], [False, False, False], [True, True, False]]
    assert matches_attacker(az, std, att, floor_deg=1.0)[0].tolist() == [True, True, False]
