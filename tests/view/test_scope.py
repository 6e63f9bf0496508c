"""The scope's and the spectrum's mathematics against numpy and scipy: a tone of known amplitude at a known bin
reads its power in dB there, the whole spectrum is scipy's periodogram, the axes of a radar frame are read right
(chirps, receivers, fast time, the I/Q pair of codes), ADC codes become samples in sqrt(W), and a beat frequency
reads as the range of the target that makes it."""
import numpy as np
import pytest
from scipy.signal import periodogram

from carav_stream.estimate.geometry import Geometry
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.adc import adc_codes, from_codes
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles
from carav_stream.view.scope import Layout, beat_range_m, layout, spectrum_db, time_axis_us, trace

FS = 150e6


@pytest.mark.parametrize("n", [1080, 255])
def test_a_real_tone_on_bin_k_reads_its_power_there_and_the_spectrum_is_scipys_periodogram(n):
    k, amplitude = 42, 0.3
    t = np.arange(n)
    x = amplitude * np.cos(2 * np.pi * k * t / n + 0.7) + 0.01 * np.random.default_rng(1).standard_normal(n)
    freqs, db = spectrum_db(x, FS)
    assert int(np.argmax(db)) == k and freqs[k] == pytest.approx(k * FS / n)
    assert db[k] == pytest.approx(10 * np.log10(amplitude ** 2 / 2), abs=0.05)      # a cosine's power, A^2 / 2
    ref_f, ref_p = periodogram(x, FS, window="hann", scaling="spectrum", detrend=False)
    np.testing.assert_allclose(freqs, ref_f)
    np.testing.assert_allclose(db, 10 * np.log10(ref_p), atol=1e-9)


def test_a_complex_tone_reads_its_power_at_its_signed_frequency_centred_or_in_fft_order():
    n, k, amplitude = 256, -30, 2.0
    z = amplitude * np.exp(2j * np.pi * k * np.arange(n) / n)
    freqs, db = spectrum_db(z, FS)
    assert freqs[0] == -FS / 2 and np.all(np.diff(freqs) > 0)                         # -fs/2 .. fs/2
    peak = int(np.argmax(db))
    assert freqs[peak] == pytest.approx(k * FS / n) and db[peak] == pytest.approx(10 * np.log10(amplitude ** 2))
    ref_f, ref_p = periodogram(z, FS, window="hann", scaling="spectrum", detrend=False, return_onesided=False)
    np.testing.assert_allclose(db, np.fft.fftshift(10 * np.log10(np.maximum(ref_p, 1e-30))), atol=1e-9)
    fft_f, fft_db = spectrum_db(z, FS, fft_order=True)                                   # 0 .. fs, as the RD map
    assert fft_f[0] == 0 and fft_f[-1] == pytest.approx(FS * (n - 1) / n)
    assert fft_f[int(np.argmax(fft_db))] == pytest.approx((n + k) * FS / n)


def test_an_empty_chirp_reads_the_floor_not_minus_infinity():
    _, db = spectrum_db(np.zeros(64), FS)
    assert np.all(np.isfinite(db)) and db.max() == pytest.approx(-300.0)


def test_the_axes_of_radar_frames_are_read_chirps_receivers_fast_time_and_the_iq_pair_of_codes():
    assert layout((1, 64, 1080), np.dtype(np.int16), iq=False) == Layout(64, 0, 1080, False)
    assert layout((1, 64, 256, 2), np.dtype(np.int16), iq=True) == Layout(64, 0, 256, True)
    assert layout((1, 64, 4, 256), np.dtype(np.complex64), iq=True) == Layout(64, 4, 256, False)
    assert layout((1, 1080), np.dtype(np.float32), iq=False) == Layout(0, 0, 1080, False)
    assert layout((1, 64, 2), np.dtype(np.int16), iq=False) == Layout(64, 0, 2, False)   # no pair without I/Q
    assert layout((1,), np.dtype(np.float64), iq=False) is None                         # one value per cycle
    assert layout((1, 2, 3, 4, 5), np.dtype(np.float32), iq=False) is None


def test_a_chirp_of_adc_codes_is_shown_in_sqrt_watts_and_its_target_at_its_range():
    scene = scene_of("table1")
    g = Geometry.from_scene(scene)
    rho = balanced_rows(np.random.default_rng(3), 1, scene.n_chirps)
    x = simulate_cycles(scene, rho, np.random.default_rng(4)).frames          # (1, n_chirps, n_samples) sqrt(W)
    codes, _, _ = adc_codes(scene, x, None)
    lay = layout(codes.shape, codes.dtype, scene.iq)
    on = int(np.flatnonzero(rho[0])[0])
    samples = trace(codes, lay, scene, chirp=on)
    np.testing.assert_array_equal(samples, from_codes(scene, codes)[0, on])
    assert trace(codes, lay, scene, chirp=10_000).shape == (scene.n_samples,)          # clipped to the last chirp
    freqs, db = spectrum_db(samples, scene.fs_hz, fft_order=True)
    peak = int(np.argmax(db[1:])) + 1                                                   # beyond DC
    # the car (43 m in table1) at its range, within a bin of range and its Doppler shift
    assert beat_range_m(freqs[peak], g) == pytest.approx(scene.targets[0].range_m, abs=2 * g.range_per_hz_m *
                                                         scene.fs_hz / scene.n_samples)
    assert time_axis_us(3, 1e6).tolist() == [0.0, 1.0, 2.0]
