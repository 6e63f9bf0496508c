"""Attackers: intended statistics (RMS, repetition, delay, timing) and no access to the current rho."""
import math

import numpy as np
import pytest

from carav_stream.radar.activation import ActivationSource
from carav_stream.radar.attackers import KINDS, AttackerError, Observation, make_attacker

C = 299_792_458.0


def emit(att, n_cycles, emission=None, seed=0, fidelity="beat", cycle0=0):
    s = att.scene
    if emission is None:
        emission = ActivationSource("seeded", seed=1).next(n_cycles, s.n_chirps)
    a, active = att.emit(n_cycles, cycle0, np.random.default_rng(seed), Observation(emission, cycle0),
                         fidelity=fidelity)
    if a is None:
        a = np.zeros((n_cycles, s.n_chirps, s.n_samples), np.complex64 if s.iq else np.float32)
    return a, active


def rms(x, axis=None):
    return np.sqrt(np.mean(np.abs(x.astype(np.complex128)) ** 2, axis=axis))


def phase_slope_hz(x, fs_hz):
    return float(np.mean(np.diff(np.unwrap(np.angle(x)))) * fs_hz / (2 * np.pi))


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("kind", ["random", "smart", "ghost"])
def test_attack_rms_is_rarms_times_sigma_n(small_scene, iq, kind):
    s = small_scene(iq=iq, sigma_n=2.0)
    a, active = emit(make_attacker(kind, s, rarms=3.0), 20)
    assert active.all()
    on = 1.0
    if kind == "ghost":     # RMS rarms while on: from its round trip (30 m: 30 samples) to the window's end
        on = 1.0 - np.ceil(2 * 30.0 / C * s.fs_hz) / s.n_samples
        assert np.all(a[:, :, :30] == 0) and np.all(np.abs(a[:, :, 31:]).max(axis=2) > 0)
    assert rms(a) == pytest.approx(6.0 * np.sqrt(on), rel=0.02)


def test_random_attack_is_white_and_independent_across_chirps(small_scene):
    s = small_scene(sigma_n=1.0)
    a, _ = emit(make_attacker("random", s, rarms=1.0), 40)
    x = a.reshape(-1, s.n_samples)
    corr = np.corrcoef(x[:-1].ravel(), x[1:].ravel())[0, 1]
    assert abs(corr) < 0.02
    assert abs(np.corrcoef(x[:, :-1].ravel(), x[:, 1:].ravel())[0, 1]) < 0.02


def test_smart_attack_repeats_one_sequence_in_every_chirp_of_a_cycle(small_scene):
    s = small_scene(iq=True)
    a, _ = emit(make_attacker("smart", s, rarms=2.0), 3)
    for c in range(3):
        assert np.array_equal(a[c], np.broadcast_to(a[c, 0], a[c].shape))
    assert not np.allclose(a[0, 0], a[1, 0])


@pytest.mark.parametrize("kind", ["smart", "random"])
def test_compact_emission_is_the_dense_one_sent_once_per_cycle_where_every_chirp_is_the_same(small_scene, kind):
    s = small_scene()
    dense, on = make_attacker(kind, s, rarms=2.0, start_cycle=1).emit(4, 0, np.random.default_rng(5))
    compact, on_c = make_attacker(kind, s, rarms=2.0, start_cycle=1).emit(4, 0, np.random.default_rng(5), compact=True)
    assert np.array_equal(on, on_c) and on.tolist() == [False, True, True, True]
    assert compact.shape == ((4, 1, s.n_samples) if kind == "smart" else dense.shape)
    assert np.array_equal(np.broadcast_to(compact, dense.shape), dense)


def test_ghost_plants_a_target_at_the_chosen_range_and_speed(small_scene):
    s = small_scene(iq=True, sigma_n=1.0)
    a, _ = emit(make_attacker("ghost", s, range_m=25.0, velocity_mps=10.0, rarms=5.0), 1)
    rdot = 10.0 - 100 / 3.6
    lam = C / 77e9
    # fast time: beat of a target at 25 m with that range rate (MATLAB sign convention)
    m0 = int(np.ceil(2 * 25.0 / C * s.fs_hz)) + 1          # it starts after the round trip it pretends
    assert phase_slope_hz(a[0, 0, m0:], s.fs_hz) == pytest.approx(2 * s.slope_hz_per_s * 25.0 / C + 2 * rdot / lam,
                                                              rel=1e-4)
    # slow time: the chirp-to-chirp phase of a target with that range rate
    step = np.angle(a[0, 1:, m0] * np.conj(a[0, :-1, m0]))
    expected = (2 * np.pi * 2 * rdot / lam * s.t_chirp_s + np.pi) % (2 * np.pi) - np.pi
    assert np.allclose(step, expected, atol=1e-3)


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_reactive_is_silent_on_silent_chirps_and_late_by_its_latency(small_scene, fidelity):
    s = small_scene(iq=True, sigma_n=1.0)
    att = make_attacker("reactive", s, distance_m=15.0, latency_s=0.4e-6, rarms=4.0)
    emission = ActivationSource("seeded", seed=3).next(2, s.n_chirps)
    a, active = emit(att, 2, emission, fidelity=fidelity)
    assert active.all()
    delay = 2 * 15.0 / C + 0.4e-6
    m_start = int(np.ceil(delay * s.fs_hz))
    guard = 17 if fidelity == "waveform" else 0                   # IF filter spreads the switch-on
    on = a[emission]
    # silent chirps: nothing once the previous chirp's replay (out of band) has ended
    tol = 1e-2 * np.abs(on).max() if fidelity == "waveform" else 0.0
    assert np.abs(a[~emission][:, m_start + guard:]).max() <= tol
    # active chirps: nothing before the delay (beyond the edges of the previous chirp's replay)
    assert np.abs(on[:, guard: m_start - guard]).max() <= tol
    assert rms(on[:, m_start + guard:]) == pytest.approx(4.0, rel=0.02)
    f = phase_slope_hz(on[0, m_start + guard:], s.fs_hz)
    assert f == pytest.approx(s.slope_hz_per_s * delay + 2 * (0 - 100 / 3.6) / (C / 77e9), rel=1e-3)


def test_lfsr_predictor_locks_on_an_lfsr_source_after_2l_bits(small_scene):
    s = small_scene(n_chirps=32, sigma_n=1.0)                   # 16 Manchester bits per cycle
    src = ActivationSource("lfsr", seed=77, taps=(16, 15, 13, 4))
    emission = src.next(6, s.n_chirps)
    att = make_attacker("lfsr_predictor", s, rarms=3.0)
    a, _ = emit(att, 6, emission)
    attacked = np.abs(a).sum(axis=2) > 0
    # 2 L = 32 bits = two cycles heard; from the third cycle on it hits exactly the active chirps
    assert np.array_equal(attacked[2:], emission[2:])
    assert att.model == (16, (4, 13, 15, 16))


def test_lfsr_predictor_is_at_chance_against_the_secure_source(small_scene):
    s = small_scene(n_chirps=64, n_samples=16, sigma_n=1.0)
    emission = ActivationSource("secure").next(30, s.n_chirps)
    att = make_attacker("lfsr_predictor", s, rarms=3.0, max_history_bits=256)
    a, _ = emit(att, 30, emission)
    attacked = np.abs(a).sum(axis=2) > 0
    hit_rate = np.mean(attacked[5:] == emission[5:])
    assert abs(hit_rate - 0.5) < 0.06                      # 1600 chirps: 4 standard deviations
    assert att.n_chirps_predicted == 30 * 64


def test_ramp_rms_rises_linearly_across_cycles(small_scene):
    s = small_scene(sigma_n=1.0, n_samples=512)
    att = make_attacker("ramp", s, rarms_start=1.0, rarms_end=5.0, n_ramp_cycles=8, start_cycle=2)
    a, active = emit(att, 14)
    assert list(active) == [False, False] + [True] * 12
    levels = rms(a, axis=(1, 2))
    expected = [0, 0] + [1 + 4 * min(i / 8, 1) for i in range(12)]
    assert np.allclose(levels, expected, rtol=0.05, atol=1e-9)


def test_start_and_duration_switch_the_attack(small_scene):
    s = small_scene()
    a, active = emit(make_attacker("random", s, start_cycle=3, n_active_cycles=2), 7)
    assert list(active) == [False, False, False, True, True, False, False]
    assert np.all(a[~active] == 0) and np.all(rms(a[active], axis=(1, 2)) > 0)


def test_secondary_antenna_power_follows_one_way_free_space(small_scene):
    s = small_scene(iq=True, targets=[], sigma_n=1e-9, adc_bits=0)
    att = make_attacker("secondary_antenna", s, range_m=40.0, velocity_mps=50 / 3.6, tx_power_w=1e-3,
                        tx_gain_db=10.0)
    emission = np.zeros((1, s.n_chirps), dtype=bool)            # victim silent: the attacker is still there
    a, active = emit(att, 1, emission, fidelity="waveform")
    lam = C / 77e9
    p_w = 1e-3 * 10 ** 1.0 * 10 ** 4.2 * lam ** 2 / (4 * math.pi * 40.0) ** 2
    tau = 40.0 / C
    m0 = int(tau * s.fs_hz) + 20
    assert active.all()
    assert rms(a[0, :, m0:-20]) == pytest.approx(math.sqrt(p_w), rel=0.01)
    assert att.equivalent_rarms() == pytest.approx(rms(a[0, :, m0:-20]) / s.sigma_n, rel=0.01)
    f = phase_slope_hz(a[0, 0, m0:-20], s.fs_hz)                 # one way: S R / c + rdot / lambda
    assert f == pytest.approx(s.slope_hz_per_s * tau + (50 - 100) / 3.6 / lam, rel=1e-3)


def test_secondary_antenna_needs_the_waveform_fidelity(small_scene):
    s = small_scene()
    att = make_attacker("secondary_antenna", s)
    assert att.needs_waveform
    with pytest.raises(ValueError, match="use fidelity 'waveform'"):
        emit(att, 1)


@pytest.mark.parametrize("kind", sorted(set(KINDS) - {"none"}))
def test_attackers_never_use_the_current_cycles_emission(small_scene, kind):
    s = small_scene(iq=True, sigma_n=1.0)
    fid = "waveform" if kind == "secondary_antenna" else "beat"
    e1 = ActivationSource("seeded", seed=4).next(4, s.n_chirps)
    e2 = e1.copy()
    e2[3] = ~e2[3]                                             # cycle 3 emits the complement
    a1, _ = emit(make_attacker(kind, s), 4, e1, seed=5, fidelity=fid)
    a2, _ = emit(make_attacker(kind, s), 4, e2, seed=5, fidelity=fid)
    assert np.array_equal(a1[:3], a2[:3])
    if kind != "reactive":
        assert np.array_equal(a1[3], a2[3])
    else:   # only after its reaction latency, in the chirps whose emission changed
        delay = make_attacker(kind, s).delay_s()
        t = np.arange(s.n_samples) / s.fs_hz
        assert np.array_equal(a1[3][:, t < delay], a2[3][:, t < delay])
        assert not np.array_equal(a1[3], a2[3])


def test_unknown_kind_and_parameters_are_named(small_scene):
    s = small_scene()
    with pytest.raises(AttackerError, match=r"unknown attacker kind 'ghots' \(did you mean 'ghost'\?\)"):
        make_attacker("ghots", s)
    with pytest.raises(AttackerError) as exc:
        make_attacker("ghost", s, rangee_m=3.0, rarms=-1.0)
    assert ("rangee_m", "unknown parameter for attacker 'ghost' (did you mean 'range_m'?)") in exc.value.problems
    assert ("rarms", "must be >= 0, got -1") in exc.value.problems


def test_random_attacker_needs_a_generator_and_reactive_an_observation(small_scene):
    s = small_scene()
    with pytest.raises(ValueError, match="pass rng_attack="):
        make_attacker("random", s).emit(1, 0, None, None)
    with pytest.raises(ValueError, match="needs observation="):
        make_attacker("reactive", s).emit(1, 0, None, None)


def test_apply_adds_to_rx_without_reading_it(small_scene):
    s = small_scene()
    rx = np.full((2, s.n_chirps, s.n_samples), 7.0, np.float32)
    rx.setflags(write=False)
    out, active = make_attacker("random", s).apply(rx, 0, np.random.default_rng(1), None)
    a, _ = make_attacker("random", s).emit(2, 0, np.random.default_rng(1), None)
    assert np.array_equal(out, rx + a) and active.all()
    assert np.all(rx == 7.0)


def test_scene_attackers_combine_and_batch_like_single_cycles(small_scene):
    from carav_stream.radar.attackers import scene_attacker
    from carav_stream.radar.synth import simulate_cycles
    s = small_scene(attackers=[{"kind": "random", "rarms": 1.0}, {"kind": "smart", "rarms": 2.0, "start_cycle": 1}])
    assert scene_attacker(small_scene()) is None
    rho = ActivationSource("seeded", seed=1).next(3, s.n_chirps)
    batch = simulate_cycles(s, rho, np.random.default_rng(0), attacker=scene_attacker(s),
                            rng_attack=np.random.default_rng(1))
    att, rng_n, rng_a = scene_attacker(s), np.random.default_rng(0), np.random.default_rng(1)
    singles = [simulate_cycles(s, rho[i: i + 1], rng_n, attacker=att, rng_attack=rng_a, cycle0=i).frames[0]
               for i in range(3)]
    assert np.array_equal(batch.frames, np.stack(singles))
    assert list(batch.attack_active) == [True, True, True]
    silent = batch.frames[0][~rho[0]]
    assert np.sqrt(np.mean(silent ** 2)) == pytest.approx(math.sqrt(1 + 1) * s.sigma_n, rel=0.1)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

PARAM_CASES = sorted((kind, p.name) for kind, cls in KINDS.items() for p in cls.declared())


@settings(max_examples=50, deadline=None)
@given(case=st.sampled_from(PARAM_CASES),
       value=st.sampled_from(["x", -1, 0, True, float("nan"), None, [1], 1e300, -1e300, 0.5]))
def test_any_parameter_value_gives_an_attacker_or_a_named_error(case, value):
    from carav_stream.radar.scene_loader import load_scene
    kind, param = case
    try:
        att = make_attacker(kind, load_scene("table1"), **{param: value})
    except AttackerError as exc:
        known = {p.name for p in KINDS[kind].declared()}
        assert exc.problems and all(p in known for p, _ in exc.problems)
    else:
        att.peak_amplitude()
        att.physics_warnings()


def test_streaming_listener_fed_one_cycle_late_equals_batch(small_scene):
    # an attacker node hears cycle c's emission only after emitting cycle c: listen() then emit(..., None)
    s = small_scene(n_chirps=32, sigma_n=1.0)
    emission = ActivationSource("lfsr", seed=5).next(5, s.n_chirps)
    batch, _ = emit(make_attacker("lfsr_predictor", s), 5, emission, seed=3)
    att, rng = make_attacker("lfsr_predictor", s), np.random.default_rng(3)
    assert att.listens
    for c in range(5):
        a, _ = att.emit(1, c, rng, None)
        att.listen(emission[c])
        assert np.array_equal(a[0], batch[c])


def _previous_reactive_cycle(a_c, main, tail, live):
    """The reactive repeater's cycle as the library computed it before the response/gating split."""
    a_c[live] += main[live]
    if tail is not None:
        prev = np.zeros_like(live)
        prev[1:] = live[:-1]
        a_c[prev] += tail[prev]
    return bool(live.any())


def _on_air_patterns(n_chirps, seed):
    """Random emission rows, plus an all-silent, an all-active and a lone-last-chirp cycle."""
    rows = np.random.default_rng(seed).random((6, n_chirps)) < 0.5
    rows[1], rows[2], rows[4] = False, True, False
    rows[4, -1] = True
    return rows


@pytest.mark.parametrize("iq", [False, True])
@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_reactive_gating_reproduces_the_per_cycle_model_bit_for_bit(small_scene, iq, fidelity):
    from carav_stream.radar import physics
    from carav_stream.radar.attackers import gate_by_emission
    s = small_scene(iq=iq, sigma_n=1.0)
    params = dict(distance_m=15.0, velocity_mps=5.0, latency_s=0.4e-6, rarms=4.0, start_cycle=1, n_active_cycles=4)
    att = make_attacker("reactive", s, **params)
    dtype = np.complex64 if iq else np.float32
    # the response is exactly the replica of physics, one row per chirp, cast once to the scene's dtype
    delay, alpha, amp = att.delay_s(), 2.0 * (5.0 - s.radar_speed_mps) / C, 4.0 * (1.0 if iq else math.sqrt(2.0))
    if fidelity == "beat":
        ref_main, ref_tail = physics.beat_replica(s, delay, alpha, amp, delay)
        ref_main = ref_main.astype(dtype)
        assert ref_tail is None               # its spill into the next slot beats far outside the IF band
    else:
        ref_main, ref_tail = (x.astype(dtype) for x in physics.waveform_replica(s, delay, alpha, amp))
    main, tail = att.response(fidelity)
    assert main.dtype == dtype and main.tobytes() == ref_main.tobytes()
    assert (tail is None) == (fidelity == "beat") and (tail is None or tail.tobytes() == ref_tail.tobytes())
    on_air = _on_air_patterns(s.n_chirps, seed=11)
    on = att.on_cycles(6, 0)
    assert on.tolist() == [False, True, True, True, True, False]
    expected = np.zeros((6, s.n_chirps, s.n_samples), dtype)
    expected_active = np.array([_previous_reactive_cycle(expected[i], main, tail, on_air[i]) if on[i] else False
                                for i in range(6)])
    assert expected_active.tolist() == [False, False, True, True, True, False]   # cycle 1: on, but all silent
    a, active = gate_by_emission(main, tail, on_air, on)
    assert a.dtype == dtype and a.tobytes() == expected.tobytes() and active.tolist() == expected_active.tolist()
    a1, active1 = gate_by_emission(main[None], None if tail is None else tail[None], on_air, on)   # one row, broadcast
    assert a1.tobytes() == expected.tobytes() and np.array_equal(active1, active)
    emitted, emitted_active = att.emit(6, 0, None, Observation(on_air, 0), fidelity=fidelity)   # library path
    assert emitted.tobytes() == expected.tobytes() and np.array_equal(emitted_active, expected_active)
    # cycle by cycle or as one batch: the same numbers
    singles = [gate_by_emission(main, tail, on_air[i: i + 1], on[i: i + 1])[0][0] for i in range(6)]
    assert np.stack(singles).tobytes() == expected.tobytes()


def test_reactive_response_does_not_depend_on_what_is_on_air(small_scene):
    s = small_scene(iq=True, sigma_n=1.0)
    att = make_attacker("reactive", s, rarms=2.0)
    before = [x.copy() for x in att.response("waveform")]
    silent, busy = np.zeros((3, s.n_chirps), bool), np.ones((3, s.n_chirps), bool)
    for emission in (silent, busy, _on_air_patterns(s.n_chirps, seed=2)[:3]):
        att.emit(3, 0, None, Observation(emission, 0), fidelity="waveform")
        after = att.response("waveform")
        assert all(np.array_equal(x, y) for x, y in zip(before, after))
    fresh = make_attacker("reactive", s, rarms=2.0).response("waveform")
    assert all(np.array_equal(x, y) for x, y in zip(before, fresh))
    # a reply for every chirp, silent or not: gating is the receiver's business
    delay_m = int(np.ceil(att.delay_s() * s.fs_hz))
    assert np.all(np.abs(before[0][:, delay_m + 17:]).min(axis=1) > 0)
    assert not any(x.flags.writeable for x in att.response("waveform"))


def test_reactive_gating_refuses_arrays_that_do_not_fit(small_scene):
    from carav_stream.radar.attackers import gate_by_emission
    s = small_scene()
    main, _ = make_attacker("reactive", s).response("beat")
    on_air = np.ones((2, s.n_chirps), bool)
    with pytest.raises(ValueError, match=r"on_air: expected bool \(n_cycles, n_chirps\), got int64"):
        gate_by_emission(main, None, on_air.astype(np.int64))
    with pytest.raises(ValueError, match=r"main: expected \(\[1 \| 3,\] 8, n_samples\)"):
        gate_by_emission(np.stack([main, main]), None, np.ones((3, s.n_chirps), bool))
    with pytest.raises(ValueError, match="tail: expected float32"):
        gate_by_emission(main, main[:4], on_air)
    with pytest.raises(ValueError, match=r"on: expected bool \(2,\)"):
        gate_by_emission(main, None, on_air, np.ones(3, bool))


@pytest.mark.parametrize("latency_us", [0.1, 2.0, 5.0])
def test_reactive_reply_agrees_between_fidelities_spill_included(latency_us):
    # The repeater cannot stop before its delay after the radar stops: its reply spills that long into the next
    # slot, in band once the delay passes the longest visible round trip (table1: half a chirp). Both fidelities
    # render the same samples there and in the reply's own slot (away from the gating edges).
    from carav_stream.radar import physics
    from carav_stream.radar.scene_loader import load_scene
    s = load_scene("table1", {"n_chirps": 8, "sigma_n": 1.0})
    on_air = np.array([[True, False, True, True, False, False, True, False]])
    out = {}
    for fid in ("beat", "waveform"):
        att = make_attacker("reactive", s, distance_m=30.0, latency_s=latency_us * 1e-6, rarms=1.0)
        out[fid], _ = att.emit(1, 0, None, Observation(on_air, 0), fidelity=fid)
    beat, wave = out["beat"][0], out["waveform"][0]
    delay = att.delay_s()
    m0 = int(round((delay - s.t_adc_start_s) * s.fs_hz))          # the sample where the reply's gating edge falls
    keep = np.ones(s.n_samples, bool)
    keep[:18] = keep[-18:] = False
    keep[max(0, m0 - 18): m0 + 18] = False
    assert np.abs(beat[:, keep] - wave[:, keep]).max() < 5e-3 * math.sqrt(2)
    _, f_spill = physics.replica_beats_hz(s, delay, 2 * (0 - s.radar_speed_mps) / C)
    spill = beat[4, : m0 - 1]                       # silent slot 4 after active slot 3
    if physics.in_band(s, f_spill):
        assert latency_us == 5.0 and np.sqrt(np.mean(spill ** 2)) == pytest.approx(1.0, rel=0.05)
    else:
        assert np.all(spill == 0)
    assert np.all(beat[5] == 0) and np.all(beat[1, m0 + 1:] == 0)   # silent after silent; nothing of its own
