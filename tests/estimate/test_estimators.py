"""estimate(): planted targets, CRLB efficiency, active chirps only, robustness, error messages."""
import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.estimate import METHODS, Geometry, estimate
from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.estimate.tones import centroid_ranges, random_rho, synth_beat

# the subspace methods take seconds on the wide cases, the others milliseconds: only their cases leave --quick
METHODS_SLOW_MARKED = [pytest.param(m, marks=pytest.mark.slow) if m in ("music", "root_music") else m for m in METHODS]

# a small waveform keeps the tests fast: 32 chirps of 128 samples, 1.17 m bins, +-19 m/s
SMALL = Geometry(fs_hz=20e6, slope_hz_per_s=20e6 / 1e-6 * 0.2, fc_hz=77e9, t_chirp_s=50e-6, n_samples=128, iq=True)
SMALL_REAL = dataclasses.replace(SMALL, iq=False)


def _data(g, n_cycles, ranges, vels, snr_db, seed, amps=1.0, all_chirps=False, migrate=False):
    rng = np.random.default_rng(seed)
    rho = np.ones((n_cycles, 32), bool) if all_chirps else random_rho(rng, n_cycles, 32)
    return synth_beat(g, rho, ranges, vels, amplitudes=amps, snr_sample_db=snr_db, rng=rng, migrate=migrate), rho


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(method=st.sampled_from(METHODS), iq=st.booleans(), range_m=st.floats(5.0, 60.0),
       velocity=st.floats(-15.0, 15.0), seed=st.integers(0, 2**31))
def test_every_method_recovers_planted_target_within_one_range_bin(method, iq, range_m, velocity, seed):
    g = SMALL if iq else SMALL_REAL
    x, rho = _data(g, 3, [range_m], [velocity], 0.0, seed)
    e = estimate(x, rho, g, method=method)
    assert e.range_m.shape == (3, 1)
    assert np.all(np.abs(e.range_m - range_m) < g.range_resolution_m)
    v_bin = 2 * g.max_velocity_mps / 32
    assert np.all(np.abs(e.velocity_mps - velocity) < v_bin)


@pytest.mark.parametrize("iq", [True, False])
def test_ml_reaches_crlb_at_20_db_after_integration(iq):
    g = SMALL if iq else SMALL_REAL
    rng = np.random.default_rng(21)
    n = 400
    ranges = 30.0 + rng.uniform(-0.6, 0.6, (n, 1))
    vels = 4.0 + rng.uniform(-1, 1, (n, 1))
    rho = random_rho(rng, n, 32)
    snr_sample = 20.0 - 10 * np.log10(16)
    x = synth_beat(g, rho, ranges, vels, snr_sample_db=snr_sample, rng=rng)
    e = estimate(x, rho, g, method="ml")
    bound = fmcw_crlb(g, snr_sample, rho)
    r_ratio = np.sqrt(np.mean((e.range_m - ranges) ** 2) / np.mean(bound["range_m"] ** 2))
    v_ratio = np.sqrt(np.mean((e.velocity_mps - vels) ** 2) / np.mean(bound["velocity_mps"] ** 2))
    assert 0.85 < r_ratio < 1.2
    assert 0.85 < v_ratio < 1.2


def test_fft_peak_error_is_grid_limited_at_high_snr():
    x, rho = _data(SMALL, 200, [30.3], [2.0], 40.0, 2)
    e = estimate(x, rho, SMALL, method="fft_peak")
    # a grid estimate cannot be better than the distance from the truth to the nearest range bin
    bins = SMALL.range_per_hz_m * SMALL.fs_hz / SMALL.n_samples
    grid_err = np.min(np.abs(np.arange(0, 80) * bins - SMALL.range_from_beat(SMALL.beat_from_range(30.3, 2.0))))
    assert np.median(np.abs(e.range_m - 30.3)) > 0.5 * grid_err


@pytest.mark.parametrize("method", METHODS)
def test_silent_chirps_are_never_used(method):
    x, rho = _data(SMALL, 4, [30.0], [3.0], 10.0, 3)
    junk = x.copy()
    rng = np.random.default_rng(9)
    junk[~rho] += (1e3 * np.exp(2j * np.pi * 0.3 * np.arange(128))).astype(np.complex64) \
        * rng.standard_normal((int((~rho).sum()), 1))
    a, b = estimate(x, rho, SMALL, method=method), estimate(junk, rho, SMALL, method=method)
    np.testing.assert_array_equal(a.range_m, b.range_m)
    np.testing.assert_array_equal(a.velocity_mps, b.velocity_mps)


def test_receding_target_has_positive_velocity_and_coupling_is_removed():
    g = SMALL
    x, rho = _data(g, 2, [25.0], [10.0], None, 4, migrate=True)     # noise-free, the range walking as echoes do
    e = estimate(x, rho, g, method="ml")
    np.testing.assert_allclose(e.velocity_mps, 10.0, atol=1e-5)
    beat_only = e.beat_hz * g.range_per_hz_m
    np.testing.assert_allclose(beat_only - e.range_m, g.range_per_hz_m * 2 * e.velocity_mps / g.wavelength_m,
                               rtol=1e-9)
    np.testing.assert_allclose(e.range_m, centroid_ranges(g, rho, [[25.0]], [[10.0]]), atol=1e-6)
    un = estimate(x, rho, g, method="ml", couple=False)
    np.testing.assert_allclose(un.range_m, beat_only, rtol=1e-12)


@pytest.mark.parametrize("method", ["ml", "music", "root_music"])
def test_noise_free_input_is_exact_and_tiny_amplitudes_scale(method):
    x, rho = _data(SMALL, 3, [33.3], [-7.7], None, 5, migrate=True)
    e = estimate(x, rho, SMALL, method=method)
    np.testing.assert_allclose(e.range_m, centroid_ranges(SMALL, rho, [[33.3]], [[-7.7]]), atol=1e-3)
    np.testing.assert_allclose(e.velocity_mps, -7.7, atol=1e-3)
    tiny = estimate(x * np.float32(1e-30), rho, SMALL, method=method)
    np.testing.assert_allclose(tiny.range_m, e.range_m, atol=1e-6)
    np.testing.assert_allclose(tiny.amplitude, 1e-30, rtol=1e-3)
    huge = estimate(x * np.float32(1e30), rho, SMALL, method=method)
    np.testing.assert_allclose(huge.range_m, e.range_m, atol=1e-6)


def test_order_estimation_finds_zero_one_and_two_targets():
    rng = np.random.default_rng(6)
    rho = random_rho(rng, 3, 32)
    noise = (rng.standard_normal((3, 32, 128)) + 1j * rng.standard_normal((3, 32, 128))).astype(np.complex64)
    e0 = estimate(noise, rho, SMALL, n_targets=None)
    assert np.all(e0.n_found == 0) and np.all(np.isnan(e0.range_m))
    x1, rho1 = _data(SMALL, 3, [20.0], [1.0], 0.0, 7)
    assert np.all(estimate(x1, rho1, SMALL, n_targets=None).n_found == 1)
    x2, rho2 = _data(SMALL, 3, [[20.0, 45.0]], [[1.0, -6.0]], 0.0, 8, amps=[[1.0, 0.7]])
    e2 = estimate(x2, rho2, SMALL, n_targets=None, criterion="aic")
    assert np.all(e2.n_found == 2)
    np.testing.assert_allclose(np.sort(e2.range_m, axis=1), [[20.0, 45.0]] * 3, atol=0.3)  # ~4 sigma


@pytest.mark.parametrize("method", METHODS_SLOW_MARKED)
def test_closely_spaced_targets_give_finite_answers_near_the_pair(method):
    x, rho = _data(SMALL, 3, [[30.0, 30.7]], [[2.0, 2.0]], 20.0, 10)
    e = estimate(x, rho, SMALL, method=method, n_targets=2)
    assert np.all(np.isfinite(e.range_m))
    assert np.all(np.abs(e.range_m - 30.35) < 3 * SMALL.range_resolution_m)


def test_empty_and_broken_cycles_give_nan_without_touching_others():
    x, rho = _data(SMALL, 4, [30.0], [3.0], 10.0, 11)
    x[0] = 0
    x[1, rho[1].argmax(), 5] = np.nan
    rho = rho.copy()
    rho[2] = False
    e = estimate(x, rho, SMALL)
    assert np.all(np.isnan(e.range_m[:3])) and np.all(e.n_found[:3] == 0)
    assert abs(e.range_m[3, 0] - 30.0) < 0.1


@pytest.mark.slow
def test_random_silencing_costs_what_the_bound_predicts():
    rng = np.random.default_rng(12)
    n = 300
    vels = 3.0 + rng.uniform(-1, 1, (n, 1))
    res = {}
    for name, rho in [("all", np.ones((n, 32), bool)), ("half", random_rho(rng, n, 32))]:
        x = synth_beat(SMALL, rho, [30.0], vels, snr_sample_db=-5.0, rng=rng)
        e = estimate(x, rho, SMALL)
        bound = fmcw_crlb(SMALL, -5.0, rho)["velocity_mps"]
        res[name] = (np.sqrt(np.mean((e.velocity_mps - vels) ** 2)), np.sqrt(np.mean(bound ** 2)))
    measured = res["half"][0] / res["all"][0]
    predicted = res["half"][1] / res["all"][1]
    assert measured == pytest.approx(predicted, rel=0.2)
    assert measured > 1.2


def test_estimates_agree_with_radar_simulator_table1():
    import carav_stream.radar.scene_loader as scene_mod
    import carav_stream.radar.synth as synth
    sc = scene_mod.load_scene("table1")
    rng = np.random.default_rng(13)
    rho = random_rho(rng, 6, sc.n_chirps)
    cyc = synth.simulate_cycles(sc, rho, rng)
    e = estimate(cyc.frames, rho, Geometry.from_scene(sc))
    np.testing.assert_allclose(e.range_m, 43.0, atol=0.02)
    np.testing.assert_allclose(e.velocity_mps, sc.range_rate_mps(sc.targets[0]), atol=0.05)


@pytest.mark.parametrize("kwargs,match", [
    (dict(method="fft"), "method must be one of"),
    (dict(n_targets=0), "n_targets"),
    (dict(zeropad=0), "zeropad"),
])
def test_bad_options_are_named(kwargs, match):
    x, rho = _data(SMALL, 1, [30.0], [0.0], 0.0, 14)
    with pytest.raises(ValueError, match=match):
        estimate(x, rho, SMALL, **kwargs)


def test_bad_inputs_are_named():
    x, rho = _data(SMALL, 1, [30.0], [0.0], 0.0, 15)
    with pytest.raises(ValueError, match="128 samples per chirp.*n_samples is 64"):
        estimate(x, rho, dataclasses.replace(SMALL, n_samples=64))
    with pytest.raises(ValueError, match="complex.*iq is False"):
        estimate(x, rho, SMALL_REAL)
    with pytest.raises(TypeError, match="rho must be bool.*int64"):
        estimate(x, rho.astype(np.int64), SMALL)
    with pytest.raises(ValueError, match=r"rho has shape \(1, 31\)"):
        estimate(x, rho[:, :31], SMALL)
    with pytest.raises(ValueError, match="frames must be"):
        estimate(x[0], rho, SMALL)


def _uneven_rho(rng, n_cycles, n_chirps):
    """Activation patterns with every count that matters: none, one, two, a few, half, all but one, all."""
    counts = [0, 1, 2, 5, n_chirps // 2, n_chirps - 1, n_chirps]
    counts = counts + list(rng.integers(0, n_chirps + 1, n_cycles - len(counts)))
    rho = np.zeros((n_cycles, n_chirps), bool)
    for c, k in enumerate(counts[:n_cycles]):
        rho[c, rng.choice(n_chirps, k, replace=False)] = True
    return rho


@pytest.mark.parametrize("method", METHODS_SLOW_MARKED)
@pytest.mark.parametrize("iq", [True, False])
@pytest.mark.parametrize("n_targets", [1, 2, None])
def test_batch_with_uneven_active_counts_equals_cycle_by_cycle(method, iq, n_targets):
    # the active chirps are compacted to the largest count of the batch, padding the others: a cycle's result
    # must not depend on its neighbours (padding rows, the range-bin pruning of the Doppler search)
    g = SMALL if iq else SMALL_REAL
    rng = np.random.default_rng(30)
    rho = _uneven_rho(rng, 10, 32)
    x = synth_beat(g, rho, [[24.0, 41.0]], [[3.0, -8.0]], amplitudes=[[1.0, 0.6]], snr_sample_db=0.0, rng=rng)
    x[7, rho[7]] = x[7, rho[7]] * np.float32(1e-3)  # near noise level: a wide search for that cycle
    x[~rho] = 7.0  # silent chirps are never read
    e = estimate(x, rho, g, method=method, n_targets=n_targets)
    assert np.all(e.n_found[:1] == 0) and np.all(np.isnan(e.range_m[0]))
    assert np.all(np.isnan(e.velocity_mps[1])) and np.all(np.isfinite(e.velocity_mps[2:, :1]))
    for c in range(rho.shape[0]):
        one = estimate(x[c:c + 1], rho[c:c + 1], g, method=method, n_targets=n_targets)
        assert one.n_found[0] == e.n_found[c]
        k = one.range_m.shape[1]
        if k != e.range_m.shape[1]:  # n_targets=None: the batch's width picks one- or several-target search
            continue
        np.testing.assert_allclose(one.range_m[0], e.range_m[c, :k], rtol=0, atol=1e-5)  # float32 rounding
        np.testing.assert_allclose(one.velocity_mps[0], e.velocity_mps[c, :k], rtol=0, atol=1e-5)
        np.testing.assert_allclose(one.amplitude[0], e.amplitude[c, :k], rtol=1e-5)


@pytest.mark.parametrize("md_factor", [1, 4])
@pytest.mark.parametrize("iq", [True, False])
@pytest.mark.parametrize("snr", [None, 10.0, -20.0])  # pruned to a few range bins ... whole map
def test_range_doppler_search_finds_the_global_maximum_of_the_full_map(md_factor, iq, snr):
    from carav_stream.estimate.estimators import _Chirps, _normalise, _search
    g = SMALL if iq else SMALL_REAL
    rng = np.random.default_rng(31)
    rho = _uneven_rho(rng, 12, 32)
    x = synth_beat(g, rho, [[33.0]], [[5.0]], snr_sample_db=snr, rng=rng)
    chirps = _Chirps.of(rho)
    xc, _, _ = _normalise(x, chirps)
    full = np.where(rho[..., None], x, 0).astype(x.dtype) / np.maximum(np.abs(x.view(np.float32)).max(), 1e-30)
    spec = np.fft.fft(xc, axis=-1) if iq else np.fft.rfft(xc, axis=-1)
    spec_full = np.fft.fft(full, axis=-1) if iq else np.fft.rfft(full, axis=-1)
    md = 32 * md_factor
    power = np.abs(np.fft.fft(spec_full, n=md, axis=1)) ** 2
    if not iq:
        power[:, :, [0, -1]] = 0
    l0, k0 = _search(spec.astype(np.complex64), chirps, md, iq)
    got = power[np.arange(12), l0[:, 0], k0[:, 0]]
    best = power.reshape(12, -1).max(axis=1)
    active = rho.sum(axis=1) > 0
    np.testing.assert_allclose(got[active], best[active], rtol=1e-4)


def test_non_finite_samples_in_silent_chirps_are_never_read():
    x, rho = _data(SMALL, 3, [30.0], [3.0], 10.0, 16)
    broken = x.copy()
    broken[0][~rho[0]] = np.nan
    broken[1][~rho[1]] = np.inf
    a, b = estimate(x, rho, SMALL), estimate(broken, rho, SMALL)
    np.testing.assert_array_equal(a.range_m, b.range_m)
    np.testing.assert_array_equal(a.velocity_mps, b.velocity_mps)


def _codes(g, lsb, seed, n_cycles=9):
    """ADC codes (I/Q: last axis 2) of two targets in noise, 40 codes RMS, and uneven activation patterns."""
    rng = np.random.default_rng(seed)
    rho = _uneven_rho(rng, n_cycles, 32)
    x = synth_beat(g, rho, [[24.0, 41.0]], [[3.0, -8.0]], amplitudes=[[1.0, 0.6]], snr_sample_db=5.0, rng=rng)
    x *= np.float32(40 * lsb / np.sqrt(np.mean(np.abs(x[rho]) ** 2)))
    parts = np.stack([x.real, x.imag], axis=-1) if g.iq else x
    codes = np.clip(np.rint(parts / lsb), -2048, 2047).astype(np.int16)
    codes[~rho] = 2047                                   # silent chirps are never read
    return codes, rho


@pytest.mark.parametrize("iq", [True, False])
@pytest.mark.parametrize("method,n_targets,max_speed", [("ml", 1, 0.0), ("ml", 2, 0.0), ("fft_interp", None, 0.0),
                                                         ("root_music", 1, 0.0), ("ml", 1, 30.0)])
def test_codes_with_their_step_give_what_their_samples_give(iq, method, n_targets, max_speed):
    # estimate(codes, lsb=) converts the active chirps only: every figure equals estimate(from_codes(codes)) exactly
    from carav_stream.radar.adc import from_codes

    g = SMALL if iq else SMALL_REAL
    lsb = 0.0123
    codes, rho = _codes(g, lsb, 31)
    scene = type("AdcOf", (), {"adc_full_scale": lsb * 2048, "adc_bits": 12, "iq": iq})()
    samples = from_codes(scene, codes)
    assert samples.dtype == (np.complex64 if iq else np.float32) and samples.shape == rho.shape + (128,)
    kwargs = dict(method=method, n_targets=n_targets, max_speed_mps=max_speed)
    want, got = estimate(samples, rho, g, **kwargs), estimate(codes, rho, g, lsb=lsb, **kwargs)
    assert np.isfinite(want.range_m[2:, 0]).all()
    for field in ("range_m", "velocity_mps", "beat_hz", "amplitude", "n_found"):
        np.testing.assert_array_equal(getattr(got, field), getattr(want, field), err_msg=field)


def test_codes_are_checked_against_their_step_and_the_receiver():
    codes, rho = _codes(SMALL, 0.01, 32)
    with pytest.raises(TypeError, match="int16 codes, got float32"):
        estimate(codes.astype(np.float32), rho, SMALL, lsb=0.01)
    for lsb in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="lsb must be a finite step above 0"):
            estimate(codes, rho, SMALL, lsb=lsb)
    with pytest.raises(ValueError, match=r"I/Q codes must be \(n_cycles, n_chirps, n_samples, 2\)"):
        estimate(codes[..., 0], rho, SMALL, lsb=0.01)
    with pytest.raises(ValueError, match="frames must be"):
        estimate(codes, rho, SMALL_REAL, lsb=0.01)
