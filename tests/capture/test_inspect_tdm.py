"""Capture inspection of a TDM-MIMO capture (2 TX x 4 RX, the awr1642's layout): the velocity comes from each
transmitter's own chirps, not from the chirps of a cycle as if one transmitter fired them all, and a transmitter
that does not fire is named."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from carav_stream.capture.dca1000 import Layout, decode
from carav_stream.capture.inspect import inspect_codes, layout_warnings
from tests.capture.ti_dca1000 import capture_bytes

C = 299_792_458.0
ARRAY = dict(tx_positions_wl=(0.0, 2.0), rx_positions_wl=(0.0, 0.5, 1.0, 1.5), tdm_schedule=(0, 1))
SCENE = SimpleNamespace(fs_hz=10e6, slope_hz_per_s=20e12, fc_hz=77e9, t_chirp_s=60e-6, iq=True, **ARRAY)
WAVELENGTH = C / SCENE.fc_hz
MAX_V = WAVELENGTH / (4 * 2 * SCENE.t_chirp_s)          # per transmitter repetition: a loop of 2 chirps
N_CHIRPS, N_SAMPLES, N_LOOPS = 64, 64, 32
CELL_MPS = 2 * MAX_V / N_LOOPS                           # one Doppler cell of the FFT over a slot's loops


def tdm_capture(rng, complex_data, velocity, sin_theta, sigma=40.0, amplitude=200.0, k=10, cycles=4,
                silent_slot=None, loops_rho=True):
    """Codes (cycles, 64 chirps, 4 rx, 64 samples[, 2]) and rho (whole TDM loops active or silent, half of them):
    white noise of RMS sigma plus, on the active chirps, a target in range bin k at `velocity` [m/s, receding]
    and azimuth asin(sin_theta), in closed form: chirp m = 2 l + j (slot j, fired by transmitter j) on receiver r
    carries a exp(j 2 pi (k n / N + nu m + x_{j r} sin_theta)), nu = 2 v T_c / lambda, x_{j r} = 2 j + 0.5 r.
    silent_slot: that slot's transmitter does not fire (its chirps hold the noise only)."""
    loops = np.array([rng.permutation(np.arange(N_LOOPS) < N_LOOPS // 2) for _ in range(cycles)])
    rho = np.repeat(loops, 2, axis=1) if loops_rho else np.ones((cycles, N_CHIRPS), bool)
    nu = 2 * velocity * SCENE.t_chirp_s / WAVELENGTH
    m, r, n = np.arange(N_CHIRPS), np.arange(4), np.arange(N_SAMPLES)
    x_wl = 2.0 * (m % 2)[:, None] + 0.5 * r[None, :]                                  # (chirps, rx)
    phase = 2 * np.pi * (k * n[None, None, :] / N_SAMPLES + (nu * m[:, None] + x_wl * sin_theta)[:, :, None])
    tone = amplitude * (np.exp(1j * phase) if complex_data else np.cos(phase))         # (chirps, rx, samples)
    if silent_slot is not None:
        tone[silent_slot::2] = 0.0
    shape = (cycles, N_CHIRPS, 4, N_SAMPLES)
    if complex_data:
        noise = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * sigma / math.sqrt(2)
    else:
        noise = rng.standard_normal(shape) * sigma
    x = noise + rho[:, :, None, None] * tone[None]
    codes = np.stack([x.real, x.imag], axis=-1) if complex_data else x.real
    return np.rint(codes).astype(np.int16), rho


@pytest.mark.parametrize("complex_data", [True, False])
def test_a_tdm_target_off_broadside_gets_its_velocity_from_each_transmitters_chirps(complex_data):
    # sin(theta) = 0.25: the second transmitter, 2 wavelengths on, adds half a cycle to every other chirp, which an
    # FFT over all the chirps reads as a Doppler shift of half the chirp rate (the target at -1.4 max_v, not +0.6)
    velocity, sin_theta = 0.6 * MAX_V, 0.25
    codes, rho = tdm_capture(np.random.default_rng(21), complex_data, velocity, sin_theta)
    report = inspect_codes(codes, SCENE, rho)
    top = report["cells"][0]
    assert top["range_bin"] == 10
    assert abs(top["velocity_mps"] - velocity) <= CELL_MPS
    assert report["n_slots"] == 2 and report["n_doppler"] == N_LOOPS
    assert report["max_velocity_mps"] == pytest.approx(MAX_V)
    assert top["above_floor_db"] > 20
    # the beamscan's grid in sin(theta) has steps of 2 / 64; 0.25 is on it
    assert top["azimuth_deg"] == pytest.approx(math.degrees(math.asin(sin_theta)), abs=1e-9)
    # the noise: silent loops and the map's floor, per receiver and per slot
    assert report["noise_rms"]["silent_chirps_codes"] == pytest.approx([40.0] * 4, rel=0.05)
    assert report["noise_rms"]["floor_codes"] == pytest.approx([40.0] * 4, rel=0.1)
    assert np.allclose(report["slot_noise_floor_codes"], 40.0, rtol=0.12)
    assert np.allclose(report["slot_silent_chirps_codes"], 40.0, rtol=0.07)
    # both transmitters fire: their slots' RMS agree, and their chirps hardly spread within a slot
    rms = np.array(report["slot_rms_codes"])
    assert rms.shape == (2, 4) and np.allclose(rms, rms.mean(), rtol=0.05)
    assert np.all(np.array(report["slot_chirp_rms_spread_db"]) < 3)


@pytest.mark.parametrize("velocity_factor", [-0.95, -0.3, 0.0, 0.45, 0.9])
def test_tdm_velocities_across_the_unambiguous_interval_are_right_within_one_cell(velocity_factor):
    velocity = velocity_factor * MAX_V
    # sin(theta) = 0.3: the slots differ by 0.6 cycles, most of an FFT over all the chirps' power in the alias
    codes, rho = tdm_capture(np.random.default_rng(22), True, velocity, 0.3)
    top = inspect_codes(codes, SCENE, rho)["cells"][0]
    assert top["range_bin"] == 10
    assert abs(top["velocity_mps"] - velocity) <= CELL_MPS


def test_without_a_layout_the_velocity_is_still_per_transmitter_but_no_azimuth_is_given():
    velocity = -0.7 * MAX_V
    codes, _ = tdm_capture(np.random.default_rng(23), True, velocity, 0.25, loops_rho=False)
    one_receiver_scene = SimpleNamespace(**{**vars(SCENE), "rx_positions_wl": (0.0,)})   # rx not placed
    report = inspect_codes(codes, one_receiver_scene, None)
    top = report["cells"][0]
    assert abs(top["velocity_mps"] - velocity) <= CELL_MPS and "azimuth_deg" not in top
    assert "silent_chirps_codes" not in report["noise_rms"] and "slot_silent_chirps_codes" not in report


def test_a_one_transmitter_scene_reports_no_slots():
    codes, rho = tdm_capture(np.random.default_rng(24), True, 0.3 * MAX_V, 0.0)
    one_tx = SimpleNamespace(fs_hz=10e6, slope_hz_per_s=20e12, fc_hz=77e9, t_chirp_s=60e-6, iq=True)
    report = inspect_codes(codes, one_tx, rho)
    assert not {"n_slots", "slot_rms_codes", "slot_noise_floor_codes"} & report.keys()
    assert "azimuth_deg" not in report["cells"][0]


def test_an_activation_that_splits_a_tdm_loop_is_refused():
    codes, rho = tdm_capture(np.random.default_rng(25), True, 0.0, 0.0)
    split = np.tile(np.arange(N_CHIRPS) % 2 == 0, (codes.shape[0], 1))        # slot 0 active, slot 1 silent
    with pytest.raises(ValueError, match="mix active and silent chirps"):
        inspect_codes(codes, SCENE, split)


def warnings_for(codes, rho, n_slots):
    words = np.frombuffer(capture_bytes(codes.reshape(-1, *codes.shape[2:]), True), "<i2")
    layout = Layout(4, N_SAMPLES, N_CHIRPS, True)
    return layout_warnings("cap.bin", words.size * 2, words, layout, decode(words, layout), rho, n_slots)


def test_a_transmitter_that_does_not_fire_is_named_not_taken_for_chirps_cut_wrong():
    codes, rho = tdm_capture(np.random.default_rng(26), True, 0.2 * MAX_V, 0.1, sigma=4.0, amplitude=2000.0,
                             cycles=2, silent_slot=1)
    report = inspect_codes(codes, SCENE, rho)
    rms = np.array(report["slot_rms_codes"])
    assert np.all(rms[1] < rms[0] / 100)                      # slot 1 holds the noise only: 50 dB below
    text = warnings_for(codes, rho, 2)
    assert len(text) == 1 and "TDM slots' RMS" in text[0] and "a transmitter is much weaker or does not fire" in \
        text[0], text
    # read as one transmitter, the same capture looks like chirps cut at the wrong places
    assert any("cut at the wrong places" in w for w in warnings_for(codes, rho, 1))
    both, rho = tdm_capture(np.random.default_rng(27), True, 0.2 * MAX_V, 0.1, sigma=4.0, amplitude=2000.0, cycles=2)
    assert warnings_for(both, rho, 2) == []


def test_the_capture_source_warns_of_a_transmitter_that_does_not_fire(tmp_path):
    """What `carav validate` says of a dca1000_source graph: the block's warnings carry the slots' check."""
    from blocks.dca1000_source import Dca1000Source

    codes, rho = tdm_capture(np.random.default_rng(28), True, 0.2 * MAX_V, 0.1, sigma=4.0, amplitude=2000.0,
                             cycles=1, silent_slot=1)
    path = tmp_path / "adc_data.bin"
    path.write_bytes(capture_bytes(codes.reshape(-1, *codes.shape[2:]), True))
    scene = tmp_path / "mimo.toml"
    scene.write_text(f"""name = "mimo"
fc_hz = 77e9
bandwidth_hz = {SCENE.slope_hz_per_s * 50e-6}
t_sweep_s = 50e-6
t_chirp_s = {SCENE.t_chirp_s}
fs_hz = {SCENE.fs_hz}
n_chirps = {N_CHIRPS}
n_samples = {N_SAMPLES}
iq = true
adc_bits = 16
adc_full_scale = 1.0
sigma_n = 1e-3
tx_positions_wl = [0.0, 2.0]
rx_positions_wl = [0.0, 0.5, 1.0, 1.5]
tdm_schedule = [0, 1]
""")
    pattern = "".join("1" if a else "0" for a in rho[0])
    block = Dca1000Source(path=str(path), scene=str(scene), pattern=pattern, n_rx=4)
    warnings = block.param_warnings()
    assert any("a transmitter is much weaker or does not fire" in w for w in warnings), warnings
