"""The virtual array and the range-Doppler-angle cube: positions slot-major, the cube's peak at a target's range,
Doppler and azimuth, the TDM phase removed at the Doppler bin, FFT and beamscan the same spectrum."""
from types import SimpleNamespace

import numpy as np
import pytest

from carav_stream.estimate.angle import angle_spectrum, loop_doppler, range_doppler_angle, sin_grid, virtual_cube
from carav_stream.estimate.virtual_array import VirtualArray, tdm_max_velocity_mps
from carav_stream.radar.scene_loader import load_scene
from tests.estimate import mimo_tones as mt

AWR1642 = VirtualArray(mt.AWR1642["rx"], mt.AWR1642["tx"], mt.AWR1642["schedule"])


def test_the_awr1642_layout_is_a_filled_half_wave_virtual_array_ordered_slot_major():
    assert AWR1642.positions_wl.tolist() == mt.virtual_positions().tolist() == [0, .5, 1, 1.5, 2, 2.5, 3, 3.5]
    assert AWR1642.is_filled_half_wave() and AWR1642.n_virtual == 8
    assert AWR1642.slot_of_channel.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    gapped = VirtualArray((0.0, 0.5), (0.0, 1.5))                            # tx 1 never fired: one slot
    assert gapped.positions_wl.tolist() == [0.0, 0.5] and gapped.is_filled_half_wave()
    overlap = VirtualArray((0.0, 0.5, 1.0), (0.0, 0.5), (0, 1))              # 0.5 and 1.0 twice
    assert overlap.uniform_spacing_wl() == pytest.approx(0.5) and not overlap.is_filled_half_wave()
    assert VirtualArray((0.0, 0.5, 1.7)).uniform_spacing_wl() is None


def test_an_array_is_read_from_any_scene_and_a_scene_without_one_is_the_one_antenna_radar():
    s = SimpleNamespace(rx_positions_wl=(0.0, 0.5), tx_positions_wl=(0.0, 1.0), tdm_schedule=(1, 0))
    assert VirtualArray.from_scene(s).positions_wl.tolist() == [1.0, 1.5, 0.0, 0.5]
    assert VirtualArray.from_scene(SimpleNamespace()) == VirtualArray()
    scene = load_scene("awr1642")
    assert tdm_max_velocity_mps(scene.wavelength_m, scene.t_chirp_s, 2) == pytest.approx(scene.max_velocity_mps / 2)


def test_a_schedule_naming_a_missing_transmitter_is_refused_by_name():
    with pytest.raises(ValueError, match="tdm_schedule"):
        VirtualArray((0.0,), (0.0, 2.0), (0, 2))


@pytest.mark.parametrize("iq", [True, False])
def test_the_cube_peaks_at_the_targets_range_doppler_and_azimuth_bins(iq):
    # on-grid: beat bin 40, Doppler loop bin 13 of 64 (nu = 13 / 128 per chirp), sin(theta) = 0.25 (grid step 1/32)
    n_angle = 64
    tone = mt.Tone(40 / 256, 13 / 128, np.degrees(np.arcsin(0.25)))
    x = mt.frames(np.random.default_rng(1), 2, [tone], iq=iq)
    p = range_doppler_angle(x, AWR1642, n_angle=n_angle)
    assert p.shape == (2, 64, 256 if iq else 127, n_angle)
    for c in range(2):
        d, b, a = np.unravel_index(np.argmax(p[c]), p[c].shape)
        assert (d, b + (0 if iq else 1)) == (13, 40)
        assert sin_grid(n_angle)[a] == pytest.approx(0.25)
        assert p[c, d, b, a] == pytest.approx((64 * 256 * 8 * (1.0 if iq else 0.5)) ** 2, rel=1e-4)


def test_the_cube_removes_the_tdm_phase_of_a_fast_target_and_without_it_the_angle_moves():
    # nu = 26 / 128 cycles/chirp (Doppler loop bin 26: 0.81 of the TDM's unambiguous velocity); the second slot's
    # phase 2 pi nu moves the uncompensated peak by that phase over the array
    n_angle = 256
    tone = mt.Tone(40 / 256, 26 / 128, 0.0)
    x = mt.frames(np.random.default_rng(2), 1, [tone], iq=True)
    on = range_doppler_angle(x, AWR1642, n_angle=n_angle)[0, 26, 40]
    off = range_doppler_angle(x, AWR1642, n_angle=n_angle, tdm=False)[0, 26, 40]
    assert sin_grid(n_angle)[np.argmax(on)] == pytest.approx(0.0)
    # a phase phi on the upper 4 of 8 half-wave elements moves the peak by about phi (4 x 1.0 wl) / (2 pi 10.5 wl^2)
    phi = 2 * np.pi * 26 / 128
    assert sin_grid(n_angle)[np.argmax(off)] == pytest.approx(phi * 4.0 / (2 * np.pi * 10.5), abs=0.02)
    assert loop_doppler(26, 64, 2) == pytest.approx(26 / 128)
    assert loop_doppler(40, 64, 2) == pytest.approx((40 - 64) / 128)             # bins above L/2: negative


def test_the_fft_over_a_filled_array_is_the_beamscan_and_duplicates_are_beamscanned():
    rng = np.random.default_rng(3)
    z = rng.standard_normal((5, 8)) + 1j * rng.standard_normal((5, 8))
    x = AWR1642.positions_wl
    direct = np.abs(z @ np.exp(-2j * np.pi * np.outer(x, sin_grid(64)))) ** 2
    assert np.allclose(angle_spectrum(z, AWR1642, 64), direct, rtol=1e-10)
    assert np.allclose(angle_spectrum(z, AWR1642, 63), np.abs(z @ np.exp(-2j * np.pi * np.outer(x, sin_grid(63))))
                       ** 2, rtol=1e-10)
    overlap = VirtualArray((0.0, 0.5, 1.0), (0.0, 0.5), (0, 1))
    s = 0.3
    z2 = np.exp(2j * np.pi * overlap.positions_wl * s)
    p = angle_spectrum(z2, overlap, 200)
    assert sin_grid(200)[np.argmax(p)] == pytest.approx(s) and p.max() == pytest.approx(36.0)


def test_silent_loops_weigh_nothing_in_the_cube():
    rng = np.random.default_rng(4)
    rho = np.repeat(rng.random((1, 64)) < 0.5, 2, axis=1)
    x = mt.frames(rng, 1, [mt.Tone(40 / 256, 13 / 128, 10.0)], iq=True)
    loud = x.copy()
    loud[:, :, ~rho[0]] += 1e3
    assert np.array_equal(virtual_cube(x, AWR1642, rho), virtual_cube(loud, AWR1642, rho))


def test_frames_of_the_wrong_shape_are_refused_naming_what_was_expected():
    with pytest.raises(ValueError, match="n_rx=4"):
        virtual_cube(np.zeros((1, 3, 128, 16), np.complex64), AWR1642)
    with pytest.raises(ValueError, match="whole loops"):
        virtual_cube(np.zeros((1, 4, 127, 16), np.complex64), AWR1642)
    with pytest.raises(ValueError, match="rho"):
        virtual_cube(np.zeros((1, 4, 128, 16), np.complex64), AWR1642, np.ones((1, 127), bool))
