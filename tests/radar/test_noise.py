"""Receiver noise (carav_stream.radar.noise): exact N(0, 1) pairs, determinism however the rows are chunked,
and the channel's fused echo add giving the same numbers as a masked add."""
import numpy as np
import pytest
import scipy.stats

from carav_stream.radar import noise, synth
from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.noise import gaussian, standard_normal_rows
from carav_stream.radar.physics import echo_templates
from carav_stream.radar.scene_loader import load_scene

BIT_GENERATORS = [np.random.PCG64, np.random.SFC64, np.random.Philox]


@pytest.mark.parametrize("bit_generator", [*BIT_GENERATORS, np.random.MT19937])
def test_noise_pairs_have_chi2_radius_and_uniform_angle(bit_generator):
    # sample j and sample h + j of a row come from the same word: (r cos theta, r sin theta)
    z = standard_normal_rows(np.random.Generator(bit_generator(11)), 8, 60_000).astype(np.float64)
    a, b = z[:, :30_000].ravel(), z[:, 30_000:].ravel()
    assert scipy.stats.kstest(a * a + b * b, "chi2", args=(2,)).pvalue > 1e-3
    assert scipy.stats.kstest(np.arctan2(b, a), "uniform", args=(-np.pi, 2 * np.pi)).pvalue > 1e-3
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.01 and abs(np.corrcoef(a * a, b * b)[0, 1]) < 0.01
    assert abs(np.corrcoef(z.ravel()[:-1], z.ravel()[1:])[0, 1]) < 0.01


@pytest.mark.parametrize("bit_generator", BIT_GENERATORS)
def test_noise_equals_box_muller_of_the_raw_words_in_float64(bit_generator):
    # independent reference: the module docstring's mapping, evaluated in float64 from the generator's raw words
    # (random_raw, whichever path noise.words takes for that generator)
    n_rows, n = 3, 2001
    h = (n + 1) // 2
    got = standard_normal_rows(np.random.Generator(bit_generator(21)), n_rows, n, 2.5).astype(np.float64)
    w = bit_generator(21).random_raw(n_rows * h).view(np.uint32).reshape(n_rows, 2 * h)
    r = 2.5 * np.sqrt(-2.0 * np.log((w[:, :h] + 0.5) * 2.0 ** -32))
    theta = 2.0 * np.pi * w[:, h:].view(np.int32) * 2.0 ** -32
    ref = np.concatenate([r * np.cos(theta), r * np.sin(theta)], axis=1)[:, :n]
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-6 * 2.5 * 6.8)


def test_noise_tails_match_the_gaussian():
    z = standard_normal_rows(np.random.default_rng(12), 20, 100_000).ravel()
    for k in (2.0, 3.0):
        expected = 2 * scipy.stats.norm.sf(k) * z.size
        assert abs(np.count_nonzero(np.abs(z) > k) - expected) < 5 * np.sqrt(expected)
    assert np.abs(z).max() < 6.8                       # u1 >= 2^-33


@pytest.mark.parametrize("n_per_row", [1, 2, 7, 1001, 70_400])
def test_noise_does_not_depend_on_chunking(monkeypatch, n_per_row):
    whole = standard_normal_rows(np.random.default_rng(5), 5, n_per_row, 3.0)
    monkeypatch.setattr(noise, "CHUNK_WORDS", 1)        # one row per chunk
    rows = standard_normal_rows(np.random.default_rng(5), 5, n_per_row, 3.0)
    rng = np.random.default_rng(5)
    one_by_one = np.concatenate([standard_normal_rows(rng, 1, n_per_row, 3.0) for _ in range(5)])
    assert whole.shape == (5, n_per_row)
    assert np.array_equal(whole, rows) and np.array_equal(whole, one_by_one)


@pytest.mark.parametrize("complex_", [False, True])
def test_gaussian_out_fills_the_given_array(complex_):
    shape, dtype = (3, 4, 50), (np.complex64 if complex_ else np.float32)
    out = np.full(shape, 7, dtype)
    got = gaussian(np.random.default_rng(2), shape, 0.5, complex_, out=out)
    assert got is out
    assert np.array_equal(out, gaussian(np.random.default_rng(2), shape, 0.5, complex_))
    with pytest.raises(ValueError, match="out"):
        gaussian(np.random.default_rng(2), shape, 0.5, complex_, out=np.empty((3, 4, 51), dtype))


@pytest.mark.parametrize("scale", [1e-20, 1.0, 1e20])
def test_noise_scale_outside_float32_square_range(scale):
    z = standard_normal_rows(np.random.default_rng(4), 2, 10_000, scale) / np.float64(scale)
    assert np.all(np.isfinite(z)) and np.std(z) == pytest.approx(1.0, abs=0.03)


@pytest.mark.parametrize("preset, iq, fidelity", [("table1", False, "beat"), ("table1", True, "waveform"),
                                                  ("awr1642", False, "beat")])
@pytest.mark.parametrize("chunk_bytes", [1, synth.CHANNEL_CHUNK_BYTES])   # one cycle a chunk; several
def test_channel_equals_noise_plus_masked_echo_bit_for_bit(monkeypatch, preset, iq, fidelity, chunk_bytes):
    monkeypatch.setattr(synth, "CHANNEL_CHUNK_BYTES", chunk_bytes)
    s = load_scene(preset, {"iq": iq, "n_chirps": 16})
    rho = ActivationSource("seeded", seed=3).next(5, s.n_chirps)
    rho[1] = True                                      # an all-on cycle and an all-off one
    rho[2] = False
    tx = synth.transmit(s, rho, 0, fidelity)
    rx, clean = synth.channel(s, tx, np.random.default_rng(9), 0, return_clean=True)
    ref = synth.draw_noise(s, np.random.default_rng(9), 5)
    tpl = echo_templates(s, fidelity)
    prev = np.zeros_like(rho)
    prev[:, 1:] = rho[:, :-1]
    np.add(ref, tpl.main_sum, out=ref, where=rho[:, :, None])
    if tpl.tail_sum is not None:
        np.add(ref, tpl.tail_sum, out=ref, where=prev[:, :, None])
    assert np.array_equal(rx, ref)
    assert np.all(clean[~(rho | prev)] == 0) and np.array_equal(clean[rho & ~prev], np.broadcast_to(
        tpl.main_sum, rho.shape + tpl.main_sum.shape[1:])[rho & ~prev])
