"""Capture inspection: a planted target's cell and the noise RMS a capture was written with, and the warnings
for a layout that does not fit."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from carav_stream.capture.dca1000 import Layout, decode
from carav_stream.capture.inspect import fitting_layouts, inspect_codes, layout_warnings
from tests.capture.ti_dca1000 import capture_bytes

C = 299_792_458.0
SCENE = SimpleNamespace(fs_hz=10e6, slope_hz_per_s=20e12, fc_hz=77e9, t_chirp_s=60e-6, iq=True)


def balanced_rho(rng, cycles, n_chirps):
    return np.array([rng.permutation(np.arange(n_chirps) < n_chirps // 2) for _ in range(cycles)])


def planted(rng, complex_data, sigma, amplitude, k, l, cycles=4, n_chirps=32, n_rx=2, n_samples=64,
            every_chirp=False):
    """Codes (cycles, n_chirps, n_rx, n_samples[, 2]): white noise of RMS sigma (E|x|^2 = sigma^2) plus, on the
    active chirps (half of them, or all), a tone in range bin k and Doppler bin l: a exp(j 2 pi (k n / N + l m / M))."""
    rho = np.ones((cycles, n_chirps), bool) if every_chirp else balanced_rho(rng, cycles, n_chirps)
    n, m = np.arange(n_samples), np.arange(n_chirps)
    phase = 2 * np.pi * (k * n[None, :] / n_samples + l * m[:, None] / n_chirps)      # (chirps, samples)
    tone = amplitude * (np.exp(1j * phase) if complex_data else np.cos(phase))
    shape = (cycles, n_chirps, n_rx, n_samples)
    if complex_data:
        noise = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * sigma / math.sqrt(2)
    else:
        noise = rng.standard_normal(shape) * sigma
    x = noise + rho[:, :, None, None] * tone[None, :, None, :]
    codes = np.stack([x.real, x.imag], axis=-1) if complex_data else x.real
    return np.rint(codes).astype(np.int16), rho


@pytest.mark.parametrize("complex_data", [True, False])
def test_inspect_reports_the_planted_cell_and_the_noise_rms_it_was_written_with(complex_data):
    rng = np.random.default_rng(3)
    sigma, k, l = 40.0, 10, 5
    codes, rho = planted(rng, complex_data, sigma, 200.0, k, l)
    report = inspect_codes(codes, SCENE, rho)
    top = report["cells"][0]
    assert (top["range_bin"], top["doppler_bin"]) == (k, l)
    wavelength = C / SCENE.fc_hz
    velocity = (l / 32) * wavelength / (2 * SCENE.t_chirp_s)              # nu = 2 v T_c / lambda
    beat = k * SCENE.fs_hz / 64
    assert top["velocity_mps"] == pytest.approx(velocity)
    assert top["range_m"] == pytest.approx(C / (2 * SCENE.slope_hz_per_s) * (beat - 2 * velocity / wavelength))
    assert top["above_floor_db"] > 20
    # silent chirps: 4 cycles x 16 chirps x 64 samples per receiver -> about 1.6 % standard error
    assert report["noise_rms"]["silent_chirps_codes"] == pytest.approx([sigma, sigma], rel=0.05)
    assert report["noise_rms"]["floor_codes"] == pytest.approx([sigma, sigma], rel=0.1)
    # the active chirps all carry the same tone: D1 sees only the noise's wobble of their RMS
    assert all(d < 0.2 for d in report["chirp_d1_max"])


def test_without_rho_the_floor_still_finds_the_noise_and_the_target():
    rng = np.random.default_rng(5)
    codes, _ = planted(rng, True, 25.0, 150.0, 20, 28, every_chirp=True)
    report = inspect_codes(codes, SCENE, None)
    assert "silent_chirps_codes" not in report["noise_rms"]
    assert report["noise_rms"]["floor_codes"] == pytest.approx([25.0, 25.0], rel=0.1)
    assert (report["cells"][0]["range_bin"], report["cells"][0]["doppler_bin"]) == (20, 28)
    assert report["cells"][0]["velocity_mps"] < 0                      # Doppler bin 28 of 32 is nu = -4/32


def words_of(codes, complex_data, **kw):
    flat = codes.reshape(-1, *codes.shape[2:])
    return np.frombuffer(capture_bytes(flat, complex_data, **kw), "<i2")


def warnings_for(words, layout, rho=None, path="cap.bin"):
    whole = words[: words.size // (layout.bytes_per_cycle // 2) * (layout.bytes_per_cycle // 2)]
    return layout_warnings(path, words.size * 2, whole, layout, decode(whole, layout), rho)


def test_a_layout_that_fits_draws_no_warning():
    rng = np.random.default_rng(1)
    codes, rho = planted(rng, True, 40.0, 200.0, 10, 5)
    for lanes in (2, 4):
        layout = Layout(2, 64, 32, True, lanes=lanes)
        assert warnings_for(words_of(codes, True, lanes=lanes), layout, rho) == []


def test_offset_binary_read_as_twos_complement_is_warned_with_the_fix():
    rng = np.random.default_rng(2)
    codes, rho = planted(rng, True, 40.0, 200.0, 10, 5)
    words = words_of(codes, True, encoding="offset_binary")
    text = warnings_for(words, Layout(2, 64, 32, True), rho)
    assert any('probably encoding = "offset_binary"' in w for w in text), text
    assert warnings_for(words, Layout(2, 64, 32, True, encoding="offset_binary"), rho) == []


def test_a_four_lane_capture_read_as_two_lanes_is_warned_with_the_fix():
    rng = np.random.default_rng(4)
    codes, rho = planted(rng, False, 40.0, 200.0, 10, 5)           # 2 receivers over 4 lanes: 2 lanes empty
    words = words_of(codes, False, lanes=4)
    text = warnings_for(words, Layout(4, 64, 32, False, lanes=2), rho)   # same size per cycle: it "fits"
    assert any("probably lanes = 4" in w for w in text), text
    assert warnings_for(words, Layout(2, 64, 32, False, lanes=4), rho) == []


def test_a_size_that_is_not_whole_cycles_names_the_layouts_that_fit():
    rng = np.random.default_rng(6)
    codes, rho = planted(rng, True, 40.0, 200.0, 10, 5, n_rx=4)
    words = words_of(codes, True)                                    # 4 receivers, complex, 2 lanes
    text = warnings_for(words, Layout(3, 64, 32, True), rho)
    assert any("not a whole number of cycles" in w and "lanes = 2, n_rx = 4, complex" in w for w in text), text
    assert Layout(4, 64, 32, True) in fitting_layouts(words.size * 2, Layout(3, 64, 32, True))


def test_chirps_of_wildly_unequal_rms_are_warned_about():
    rng = np.random.default_rng(7)
    codes, rho = planted(rng, True, 4.0, 2000.0, 10, 5)            # silent chirps 50 dB below active ones
    words = words_of(codes, True)
    assert warnings_for(words, Layout(2, 64, 32, True), rho) == []
    wrong = balanced_rho(np.random.default_rng(8), 4, 32)           # another capture's activation log
    text = warnings_for(words, Layout(2, 64, 32, True), wrong)
    assert any("activation log is not this capture's" in w for w in text), text
