"""Signal chain: dechirp convention, radar equation, fidelities, stage composition, ADC, Swerling."""
import math

import numpy as np
import pytest
import scipy.fft
import scipy.stats

from carav_stream.radar import synth
from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.adc import adc
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.noise import standard_normal_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import (
    channel,
    echo_energy_per_chirp,
    observe,
    resolve_fidelity,
    simulate_cycles,
    transmit,
)

C = 299_792_458.0


def all_on(scene, n_cycles=1):
    return np.ones((n_cycles, scene.n_chirps), dtype=bool)


def clean(scene, rho=None, fidelity="beat"):
    rho = all_on(scene) if rho is None else rho
    return simulate_cycles(scene, rho, np.random.default_rng(0), fidelity=fidelity, return_clean=True).clean_echo


def phase_slope_hz(x, fs_hz):
    return float(np.mean(np.diff(np.unwrap(np.angle(x)))) * fs_hz / (2 * np.pi))


def test_table1_car_fft_peak_at_5_87_mhz():
    s = load_scene("table1", {"iq": True})
    x = clean(s)[0, 0]
    spectrum = np.abs(scipy.fft.fft(x))
    f = scipy.fft.fftfreq(s.n_samples, 1 / s.fs_hz)
    f_peak = f[np.argmax(spectrum)]
    assert f_peak > 0                                  # MATLAB convention: positive beat
    assert abs(f_peak - 5.87e6) <= s.fs_hz / s.n_samples
    range_m = f_peak * C / (2 * s.slope_hz_per_s)
    assert abs(range_m - 43.0) <= s.range_resolution_m


@pytest.mark.parametrize("velocity_kmh", [-200.0, 20.0, 100.0, 250.0])
def test_dechirp_beat_is_range_beat_minus_doppler(small_scene, velocity_kmh):
    s = small_scene(iq=True, targets=[{"range_m": 43.0, "velocity_kmh": velocity_kmh, "rcs_m2": 100.0}])
    rdot = (velocity_kmh - 100.0) / 3.6                     # + = receding
    f_doppler = -2 * rdot / (C / 77e9)                      # > 0 when closing
    expected = 2 * s.slope_hz_per_s * 43.0 / C - f_doppler
    m0 = int(np.ceil(2 * 43.0 / C * s.fs_hz)) + 1          # the echo arrives after its round trip
    measured = phase_slope_hz(clean(s)[0, 0, m0:], s.fs_hz)
    assert measured == pytest.approx(expected, rel=1e-5)
    assert np.all(clean(s)[0, 0, : m0 - 1] == 0)


def test_chirp_to_chirp_phase_advances_by_doppler(small_scene):
    s = small_scene(iq=True, targets=[{"range_m": 43.0, "velocity_kmh": 40.0, "rcs_m2": 100.0}])
    x = clean(s)[0]
    rdot = (40.0 - 100.0) / 3.6
    expected = 2 * np.pi * 2 * rdot / (C / 77e9) * s.t_chirp_s   # -2 pi f_D T (tau shrinks when closing)
    step = np.angle(x[1:, 100] * np.conj(x[:-1, 100]))
    wrapped = (expected + np.pi) % (2 * np.pi) - np.pi
    assert np.allclose(step, wrapped, atol=1e-3)


def test_i_only_is_the_in_phase_branch_of_iq(small_scene):
    xi = clean(small_scene(iq=False))
    xq = clean(small_scene(iq=True))
    assert xi.dtype == np.float32 and xq.dtype == np.complex64
    assert np.allclose(xi, xq.real, atol=1e-6 * np.abs(xq).max())


@pytest.mark.parametrize("iq", [False, True])
def test_radar_equation_snr_is_what_the_samples_show(iq):
    s = load_scene("table1", {"iq": iq, "adc_bits": 0})
    rho = ActivationSource("seeded", seed=1).next(4, s.n_chirps)
    c = simulate_cycles(s, rho, np.random.default_rng(1), return_clean=True)
    m0 = int(np.ceil(2 * s.targets[0].range_m / C * s.fs_hz))    # the echo is there from its round trip on
    echo_w = np.mean(np.abs(c.clean_echo[rho][:, m0:]) ** 2)
    noise = c.frames - c.clean_echo
    assert np.sqrt(np.mean(np.abs(noise) ** 2)) == pytest.approx(s.sigma_n, rel=0.01)
    assert 10 * np.log10(echo_w / s.sigma_n ** 2) == pytest.approx(2.2, abs=0.05)
    assert np.all(c.clean_echo[~rho] == 0)


def test_noise_is_gaussian_with_unit_variance():
    z = standard_normal_rows(np.random.default_rng(3), 4, 50_000).ravel()
    assert scipy.stats.kstest(z, "norm").pvalue > 1e-3
    assert np.var(z) == pytest.approx(1.0, abs=0.02)
    assert scipy.stats.kurtosis(z) == pytest.approx(0.0, abs=0.1)


def test_noise_rows_equal_one_row_calls():
    a = standard_normal_rows(np.random.default_rng(5), 3, 1001)
    rng = np.random.default_rng(5)
    b = np.concatenate([standard_normal_rows(rng, 1, 1001) for _ in range(3)])
    assert np.array_equal(a, b)


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("kind", ["none", "random", "smart", "ramp", "lfsr_predictor", "ghost", "reactive"])
def test_batch_equals_stage_by_stage_bit_for_bit(small_scene, iq, kind, monkeypatch):
    s = small_scene(iq=iq, adc_bits=10, targets=[
        {"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0, "swerling": 1},
        {"range_m": 20.0, "rcs_m2": 10.0, "swerling": 2}, {"range_m": 60.0, "rcs_m2": 50.0}])
    rho = ActivationSource("seeded", seed=2).next(5, s.n_chirps)
    params = {"start_cycle": 1} if kind != "none" else {}
    batch = simulate_cycles(s, rho, np.random.default_rng(7), rng_attack=np.random.default_rng(8),
                            attacker=make_attacker(kind, s, **params), fidelity="beat")
    rng_n, rng_a = np.random.default_rng(7), np.random.default_rng(8)
    att = make_attacker(kind, s, **params)
    for i in range(5):
        tx = transmit(s, rho[i: i + 1], i, "beat")
        rx = channel(s, tx, rng_n, i)
        rx, active = att.apply(rx, i, rng_a, observe(tx), fidelity="beat")
        frames, clipped = adc(s, rx)
        assert np.array_equal(frames[0], batch.frames[i])
        assert clipped[0] == batch.clipped[i] and active[0] == batch.attack_active[i]
    # chunked internally (2 cycles per chunk): still the same numbers
    monkeypatch.setattr(synth, "CHUNK_BYTES", 2 * s.n_chirps * s.n_samples * (8 if iq else 4))
    chunked = simulate_cycles(s, rho, np.random.default_rng(7), rng_attack=np.random.default_rng(8),
                              attacker=make_attacker(kind, s, **params), fidelity="beat")
    assert np.array_equal(chunked.frames, batch.frames)


def test_waveform_batch_equals_stage_by_stage(small_scene):
    s = small_scene(iq=True)
    rho = ActivationSource("seeded", seed=2).next(3, s.n_chirps)
    mk = lambda: make_attacker("secondary_antenna", s, tx_power_w=1e-6, t_chirp_s=7.5e-6)  # drifts per cycle
    batch = simulate_cycles(s, rho, np.random.default_rng(1), attacker=mk())
    assert batch.fidelity == "waveform"
    rng, att = np.random.default_rng(1), mk()
    for i in range(3):
        tx = transmit(s, rho[i: i + 1], i, "waveform")
        rx, _ = att.apply(channel(s, tx, rng, i), i, None, observe(tx), fidelity="waveform")
        assert np.array_equal(adc(s, rx)[0][0], batch.frames[i])


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("preset", ["table1", "awr1642"])
def test_beat_and_waveform_fidelities_agree_within_tolerance(preset, iq):
    s = load_scene(preset, {"iq": iq, "n_chirps": 8})
    beat = clean(s, fidelity="beat")[0]
    wave = clean(s, fidelity="waveform")[0]
    tau = 2 * s.targets[0].range_m / C
    settle = 16 + 2                                   # FIR half length in ADC samples, plus margin
    m0 = _sample_at(s, tau) + settle
    interior = slice(m0, s.n_samples - settle)
    amp = np.abs(beat[:, interior]).max()
    # stated tolerance (docs/SCENES.md): 0.5 % of the echo amplitude inside the window
    assert np.abs(wave[:, interior] - beat[:, interior]).max() < 5e-3 * amp
    # before the echo of this chirp arrives the waveform model holds (almost) nothing (a window starting at the
    # ramp's reset: its first samples hold the previous chirp's in-band echo, cut off by the reset)
    lead = max(0, settle - _sample_at(s, 0.0))
    if m0 > 2 * settle + lead:
        assert np.abs(wave[:, lead: m0 - 2 * settle]).max() < 0.02 * amp


def _sample_at(s, t_s: float) -> int:
    """Index of the first ADC sample at or after fast time t_s (negative before the window's start)."""
    return int(np.ceil(round((t_s - s.t_adc_start_s) * s.fs_hz, 6)))


def _edges_masked(n_samples, edges, settle=18):
    """Sample mask away from the window's ends and from every gating edge (the waveform FIR smears an edge over
    +-16 samples; the beat fidelity's ideal filter does not)."""
    keep = np.ones(n_samples, bool)
    keep[:settle] = keep[-settle:] = False
    for e in edges:
        keep[max(0, e - settle): max(0, e + settle)] = False
    return keep


# (preset, round trip / chirp period): table1 samples the whole chirp with fs = B, so an echo's own beat is
# (tau / T_c) fs and its spill's -(1 - tau / T_c) fs; the cases keep both clear of the filter's transition bands
# (+-0.05 fs around the -6 dB edges, where the waveform FIR and the beat fidelity's ideal filter differ by design)
AGREEMENT_CASES = [("table1", 0.04, None), ("table1", 0.3, None), ("table1", 0.42, None), ("table1", 0.6, False),
                   ("table1", 0.8, False), ("table1", 0.6, True), ("table1", 0.8, True), ("table1", 0.97, True),
                   ("awr1642", 0.001, None), ("awr1642", 0.002, None)]


@pytest.mark.parametrize("preset, tau_over_chirp, iq_only", AGREEMENT_CASES)
@pytest.mark.parametrize("iq", [False, True])
def test_beat_and_waveform_agree_on_the_slot_and_the_spill(preset, tau_over_chirp, iq_only, iq):
    # An echo occupies its own slot from its round trip on and spills that long into the next slot, where the
    # receiver's ramp has restarted: the spill beats at S (tau - T_c) - f_D. Both fidelities must put the same
    # samples in every slot, silent or active: the echo's own part and its spill, each in band or removed.
    import dataclasses

    from carav_stream.radar import physics
    if iq_only is not None and iq_only != iq:
        pytest.skip("case for the other receiver")
    base = load_scene(preset, {"iq": iq, "n_chirps": 8})
    car = base.targets[0]
    r = tau_over_chirp * base.t_chirp_s * C / 2
    target = dataclasses.replace(car, range_m=r, rcs_m2=car.rcs_m2 * (r / car.range_m) ** 4)
    s = dataclasses.replace(base, targets=(target,))
    rho = np.array([[True, False, True, True, False, False, True, False]])
    beat, wave = (clean(s, rho, fid)[0] for fid in ("beat", "waveform"))
    amp = physics.echo_amplitude(s, target)
    tau = 2 * r / C
    m0 = max(0, _sample_at(s, tau))
    keep = _edges_masked(s.n_samples, [m0])
    assert np.abs(wave[:, keep] - beat[:, keep]).max() < 5e-3 * amp
    # energy per slot, the edges included, within 2 % of a full slot of echo
    e_beat, e_wave = (np.sum(np.abs(x.astype(np.complex128)) ** 2, axis=1) for x in (beat, wave))
    assert np.all(np.abs(e_beat - e_wave) < 0.02 * amp ** 2 * s.n_samples / (1 if iq else 2))
    f_main, f_spill = physics.replica_beats_hz(s, tau, 0.0)
    main_in, spill_in = physics.in_band(s, f_main), physics.in_band(s, f_spill)
    assert spill_in == (tau_over_chirp > (0.95 if iq else 0.55))        # the spill passes only beyond the range
    assert main_in == (tau_over_chirp < (0.9 if iq else 0.5))
    after_active = np.flatnonzero(~rho[0, 1:] & rho[0, :-1]) + 1            # silent slots after active ones
    silent_after_silent = np.flatnonzero(~rho[0, 1:] & ~rho[0, :-1]) + 1
    assert np.all(beat[silent_after_silent] == 0)
    spill = beat[after_active][:, :min(m0, s.n_samples)]
    own = beat[rho[0]][:, m0:]
    if spill_in:
        assert np.all(np.abs(spill[:, 1:]) > 0) and np.sqrt(np.mean(np.abs(spill) ** 2)) > 0.5 * amp
    else:
        assert np.all(spill == 0)
    assert np.all(own == 0) != main_in


def test_receiver_reference_keeps_sweeping_on_silent_chirps(small_scene):
    # A coherent replica on the air in every chirp period is dechirped on silent chirps too.
    s = small_scene(iq=True, targets=[], sigma_n=1e-9, adc_bits=0)
    rho = np.zeros((1, s.n_chirps), dtype=bool)
    rho[0, ::2] = True
    for fid in ("beat", "waveform"):
        ghost = make_attacker("ghost", s, range_m=30.0, rarms=1e4)
        c = simulate_cycles(s, rho, np.random.default_rng(0), attacker=ghost, fidelity=fid)
        silent = c.frames[0][~rho[0]]
        f = phase_slope_hz(silent[0, 50:200], s.fs_hz)
        assert f == pytest.approx(2 * s.slope_hz_per_s * 30.0 / C + 2 * (0 - 100 / 3.6) / (C / 77e9), rel=1e-3)


def test_auto_fidelity_picks_waveform_only_for_own_waveform_attackers(small_scene):
    s = small_scene()
    assert resolve_fidelity("auto") == "beat"
    assert resolve_fidelity("auto", make_attacker("ghost", s)) == "beat"
    assert resolve_fidelity("auto", make_attacker("secondary_antenna", s)) == "waveform"
    with pytest.raises(ValueError, match="cannot render attacker 'secondary_antenna'"):
        resolve_fidelity("beat", make_attacker("secondary_antenna", s))
    with pytest.raises(ValueError, match="unknown 'exact'"):
        resolve_fidelity("exact")


@pytest.mark.parametrize("iq", [False, True])
def test_adc_quantises_to_lsb_grid_and_counts_clipped_samples(small_scene, iq):
    s = small_scene(iq=iq, adc_bits=8, adc_full_scale=1.0, sigma_n=0.5, targets=[])
    rng = np.random.default_rng(4)
    rx = (rng.standard_normal((3, s.n_chirps, s.n_samples)) * 0.7).astype(np.float32)
    if iq:
        rx = (rx + 1j * (rng.standard_normal(rx.shape) * 0.7)).astype(np.complex64)
    frames, clipped = adc(s, rx)
    lsb = 1.0 / 128
    parts = [frames.real, frames.imag] if iq else [frames]
    for p in parts:
        codes = p / lsb
        assert np.allclose(codes, np.round(codes), atol=1e-3)
        assert codes.max() <= 127 + 1e-3 and codes.min() >= -128 - 1e-3
    over = lambda x: (x > 127.5 * lsb) | (x < -128.5 * lsb)
    expected = (over(rx.real) | over(rx.imag)) if iq else over(rx)
    assert np.array_equal(clipped, expected.reshape(3, -1).sum(axis=1))
    assert clipped.sum() > 0
    inside = ~expected
    assert np.abs(frames - rx)[inside].max() <= lsb * (0.5 if not iq else 0.71) + 1e-6


def test_ideal_adc_is_a_copy(small_scene):
    s = small_scene(adc_bits=0)
    rx = np.random.default_rng(0).standard_normal((1, s.n_chirps, s.n_samples)).astype(np.float32) * 1e3
    frames, clipped = adc(s, rx)
    assert np.array_equal(frames, rx) and clipped[0] == 0


@pytest.mark.parametrize("swerling,per_chirp,variance", [(1, False, 1.0), (2, True, 1.0), (3, False, 0.5),
                                                         (4, True, 0.5)])
def test_swerling_rcs_fluctuates_with_the_right_law(small_scene, swerling, per_chirp, variance):
    s = small_scene(targets=[{"range_m": 43.0, "rcs_m2": 100.0, "swerling": swerling}], adc_bits=0)
    gains = np.stack([synth.swerling_gains(s, rng) for rng in [np.random.default_rng(9)] for _ in range(4000)])
    rcs_ratio = gains[:, 0, :].astype(np.float64) ** 2
    constant_in_cycle = np.all(rcs_ratio == rcs_ratio[:, :1])
    assert constant_in_cycle != per_chirp
    x = rcs_ratio[:, 0]
    assert x.mean() == pytest.approx(1.0, abs=0.05)
    assert x.var() == pytest.approx(variance, rel=0.1)
    dof = 2 if swerling in (1, 2) else 4                   # sigma/mean ~ chi^2_dof / dof
    assert scipy.stats.kstest(x * dof, scipy.stats.chi2(dof).cdf).pvalue > 1e-3


def test_echo_energy_per_chirp_matches_clean_echo(small_scene):
    s = small_scene(iq=True)
    rho = ActivationSource("seeded", seed=4).next(3, s.n_chirps)
    for fid in ("beat", "waveform"):
        c = simulate_cycles(s, rho, np.random.default_rng(0), fidelity=fid, return_clean=True)
        measured = np.sum(np.abs(c.clean_echo.astype(np.complex128)) ** 2, axis=2)
        assert np.allclose(echo_energy_per_chirp(s, rho, fid), measured, rtol=1e-4, atol=1e-30)


def test_transmit_rejects_bad_activation_rows(small_scene):
    s = small_scene()
    with pytest.raises(TypeError, match="rho: expected a bool array, got dtype int64"):
        transmit(s, np.ones((1, 8), dtype=np.int64))
    with pytest.raises(ValueError, match=r"rho: expected shape \(n_cycles, 8\), got \(1, 6\)"):
        transmit(s, np.ones((1, 6), dtype=bool))


def test_frames_dtype_and_shape(table1):
    rho = ActivationSource("seeded", seed=1).next(2, 64)
    c = simulate_cycles(table1, rho, np.random.default_rng(0))
    assert c.frames.dtype == np.float32 and c.frames.shape == (2, 64, 1080)
    assert c.clean_echo is None and c.fidelity == "beat"
    assert c.clipped.dtype == np.int64 and c.attack_active.dtype == np.bool_
    assert not c.attack_active.any() and math.isfinite(float(np.abs(c.frames).max()))


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=30, deadline=None)
@given(bits=st.integers(2, 16), full_scale=st.floats(1e-6, 1e3), seed=st.integers(0, 2 ** 16))
def test_adc_error_is_at_most_half_an_lsb_inside_full_scale(bits, full_scale, seed):
    from carav_stream.radar.scene_loader import scene_from_dict
    s = scene_from_dict({"fc_hz": 77e9, "bandwidth_hz": 150e6, "t_sweep_s": 7.33e-6, "fs_hz": 150e6,
                         "n_chirps": 2, "n_samples": 64, "adc_bits": bits, "adc_full_scale": full_scale,
                         "sigma_n": 1.0}, "adc.toml")
    rx = (np.random.default_rng(seed).uniform(-1.2, 1.2, (1, 2, 64)) * full_scale).astype(np.float32)
    frames, clipped = adc(s, rx)
    lsb = full_scale / 2 ** (bits - 1)
    top, bottom = (2 ** (bits - 1) - 1) * lsb, -(2 ** (bits - 1)) * lsb
    inside = (rx < top) & (rx > bottom)
    assert np.all(np.abs(frames - rx)[inside] <= 0.5 * lsb * (1 + 1e-5) + 1e-6 * full_scale)
    assert frames.max() <= top * (1 + 1e-6) and frames.min() >= bottom * (1 + 1e-6)
    assert clipped[0] >= np.count_nonzero((rx > top + lsb) | (rx < bottom - lsb))


def test_echo_templates_are_computed_once_per_scene(small_scene):
    from carav_stream.radar import physics
    s = small_scene(n_samples=200)
    rho = ActivationSource("seeded", seed=1).next(2, s.n_chirps)
    simulate_cycles(s, rho, np.random.default_rng(0))
    misses = physics.echo_templates.cache_info().misses
    for i in range(3):
        simulate_cycles(s, rho, np.random.default_rng(i))
    assert physics.echo_templates.cache_info().misses == misses


@pytest.mark.parametrize("iq", [False, True])
def test_channel_and_adc_codes_computed_into_a_given_array_equal_their_own_bit_for_bit(small_scene, iq):
    """The out= paths the shared-memory data plane uses (the payload computed in its slot): same values, the
    given array filled and returned; a wrong shape or dtype is refused."""
    from carav_stream.radar.adc import adc_codes
    scene = small_scene(iq=iq, adc_bits=12)
    rho = ActivationSource("seeded", seed=3).next(3, scene.n_chirps)
    tx = synth.transmit(scene, rho, 0, "beat")
    own = synth.channel(scene, tx, np.random.default_rng(1), 0)
    given = np.full_like(own, np.nan)
    got = synth.channel(scene, tx, np.random.default_rng(1), 0, out=given)
    assert got is given
    np.testing.assert_array_equal(got, own)
    codes, clipped, nonfinite = adc_codes(scene, own * 1e3)
    into = np.full(codes.shape, -7, np.int16)
    codes2, clipped2, nonfinite2 = adc_codes(scene, own * 1e3, into)
    assert codes2 is into and clipped.sum() > 0
    np.testing.assert_array_equal(codes2, codes)
    np.testing.assert_array_equal(clipped2, clipped)
    with pytest.raises(ValueError, match="out must be"):
        synth.channel(scene, tx, np.random.default_rng(1), 0, out=given[:, :-1])
    with pytest.raises(ValueError, match="out must be int16"):
        adc_codes(scene, own, into.astype(np.int32))


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("chunk", [1, 5000, 9000, 1 << 16])   # 1, 2 or 4 cycles at a time, or all 5
@pytest.mark.parametrize("rows", ["every_cycle", "one_row"])
def test_adc_codes_of_a_sum_equal_the_codes_of_the_summed_signal_however_chunked(monkeypatch, small_scene, iq,
                                                                                  chunk, rows):
    """add= (the attack at the ADC input) gives the codes, clip and NaN counts of rx + add computed first, and
    the chunk size (cycles quantised at a time) changes nothing, clipping and non-finite samples included."""
    from carav_stream.radar import adc as adc_mod
    scene = small_scene(iq=iq, adc_bits=12)
    rho = ActivationSource("seeded", seed=4).next(5, scene.n_chirps)
    rx = synth.channel(scene, synth.transmit(scene, rho, 0, "beat"), np.random.default_rng(2), 0)
    a = (np.random.default_rng(3).standard_normal((5 if rows == "every_cycle" else 1, 1, rx.shape[2]))
         * 40 * scene.adc_full_scale).astype(rx.dtype)
    rx[1, 0, 3] = np.nan
    rx[3, 1, 0] = np.inf
    want = adc_mod.adc_codes(scene, rx + a)
    monkeypatch.setattr(adc_mod, "CHUNK_ELEMENTS", chunk)
    got = adc_mod.adc_codes(scene, rx, add=a)
    assert want[1].sum() > 0 and want[2][1] == 1 and want[2][3] == 1
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)
    with pytest.raises(ValueError, match="add must be"):
        adc_mod.adc_codes(scene, rx, add=a[..., :-1])


def test_if_filter_removes_an_echo_beyond_the_band_and_without_it_the_echo_folds():
    # awr1642_literal: the 20 m target beats at 10.4 MHz, beyond the 5 MHz I-only band. Its scene has no anti-alias
    # filter (MATLAB's example), so the beat fidelity folds the echo back; with the filter nothing of it is left.
    folded = load_scene("awr1642_literal", {"n_chirps": 4})
    assert not folded.if_filter
    import dataclasses
    filtered = dataclasses.replace(folded, if_filter=True)
    rho = np.ones((1, 4), bool)
    assert np.abs(clean(folded, rho)).max() > 0
    assert np.all(clean(filtered, rho) == 0)
    spec = np.abs(np.fft.rfft(clean(folded, rho)[0, 0, 20:]))
    f_peak = np.argmax(spec) * folded.fs_hz / (folded.n_samples - 20)
    assert f_peak == pytest.approx(0.38e6, abs=2 * folded.fs_hz / (folded.n_samples - 20))
