"""The radar blocks in-process: fail-closed gate, detector and estimator refusals, parameter errors."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.attacker import AttackerBlock
from carav_blocks.gate import Gate
from carav_blocks.range_estimator import RangeEstimator
from carav_blocks.rms_detector import RmsDetector
from carav_stream.block import BlockError
from carav_stream.frames import Frame, decode, encode


def wire(frame: Frame, seq: int) -> Frame:
    """What a block receives: the frame after a trip through the codec."""
    return decode(encode(frame, seq=seq, stream="x.y"))


def adc_frame(seq: int, value: float = 1e-4, cycles: int = 1) -> Frame:
    return wire(Frame.of(np.full((cycles, 64, 1100), value, np.float32), cycles=cycles), seq)


RHO = np.zeros(64, bool)
RHO[::2] = True

cycle_fields = st.fixed_dictionaries({}, optional={
    "alarm": st.one_of(st.booleans(), st.none(), st.integers(0, 1)),
    "invalid": st.one_of(st.booleans(), st.none(), st.integers(0, 1)),
    "q": st.floats(allow_nan=True)})


@settings(max_examples=100)
@given(cycles=st.lists(cycle_fields, min_size=1, max_size=4), eta=st.floats(0.1, 3))
def test_gate_never_passes_a_cycle_without_an_explicit_clean_verdict(cycles, eta):
    n = len(cycles)
    per = {}
    for name in ("alarm", "invalid", "q"):
        if all(name in c for c in cycles):
            per[name] = [c[name] for c in cycles]
    verdict = wire(Frame.of(np.tile(RHO, (n, 1)), cycles=n, eta=eta, per_cycle=per), 3)
    out = Gate().process(adc_frame(3, cycles=n), verdict)
    clean = [c.get("alarm") is False and c.get("invalid") is False and "alarm" in per and "invalid" in per
             for c in cycles]
    passed = out["clean"].header["per_cycle"]["cycle_index"] if "clean" in out else []
    refused = out["alarms"].header["per_cycle"]["cycle_index"] if "alarms" in out else []
    assert passed == [3 + i for i in range(n) if clean[i]] and refused == [3 + i for i in range(n) if not clean[i]]
    if "clean" in out:
        assert out["clean"].header["verdict"] == "clean" and out["clean"].header["cycles"] == len(passed)
        assert out["clean"].payload.shape == (len(passed), 64, 1100)
        np.testing.assert_array_equal(out["clean"].arrays["rho"], np.tile(RHO, (len(passed), 1)))


def test_gate_refuses_verdicts_that_do_not_match_the_frame():
    per = {"alarm": [False, False], "invalid": [False, False]}
    short = wire(Frame.of(np.tile(RHO, (2, 1)), cycles=2, per_cycle=per), 1)   # 2 verdicts for 3 cycles
    out = Gate().process(adc_frame(1, cycles=3), short)
    assert set(out) == {"alarms"} and out["alarms"].header["per_cycle"]["reason"] == ["bad_verdict"] * 3


def test_gate_refuses_cycle_without_verdict_and_verdict_without_frame():
    gate = Gate()
    out = gate.unpaired("frames", adc_frame(7, cycles=2))
    assert set(out) == {"alarms"} and out["alarms"].header["per_cycle"]["reason"] == ["no_verdict"] * 2
    assert out["alarms"].payload is None and out["alarms"].header["cycles"] == 2
    out = gate.unpaired("verdict", wire(Frame.of(np.ones((1, 64), bool), per_cycle={"alarm": [False],
                                                                                     "invalid": [False]}), 8))
    assert out["alarms"].header["per_cycle"]["reason"] == ["no_frame"]


def test_detector_flags_nan_frames_and_frames_without_rho():
    det = RmsDetector(eta=1.5)
    rho = np.zeros((2, 64), bool)
    rho[:, :32] = True
    frames = np.random.default_rng(0).normal(0, det.sigma, (2, 64, 1100)).astype(np.float32)
    ok = det.process(wire(Frame.of(frames, cycles=2), 1), wire(Frame.of(rho, cycles=2), 1))
    assert ok.header["per_cycle"]["alarm"] == [False, False] and max(ok.header["per_cycle"]["q"]) < 1.5
    frames[1, 5, 7] = np.nan
    bad = det.process(wire(Frame.of(frames, cycles=2), 2), wire(Frame.of(rho, cycles=2), 2)).header["per_cycle"]
    assert bad["alarm"] == [False, True] and bad["invalid"] == [False, True] and bad["raised_by"][1] == "invalid"
    lone = det.unpaired("frames", wire(Frame.of(frames, cycles=2), 3))
    assert lone.header["per_cycle"]["alarm"] == [True, True] and lone.header["reason"] == "no_rho"
    assert det.unpaired("rho", wire(Frame.of(rho), 4)) is None


def test_detector_judges_int16_codes_exactly_like_the_samples_they_stand_for():
    from carav_stream.detect.detector import detect
    from carav_stream.radar.streams import scene_of
    from carav_stream.radar.synth import adc_codes
    scene = scene_of("table1")
    det = RmsDetector(eta=1.5)
    rho = np.zeros((3, 64), bool)
    rho[:, 1::2] = True
    rx = np.random.default_rng(1).normal(0, scene.sigma_n, (3, 64, 1100)).astype(np.float32)
    rx[2, :4] *= 5   # an attacked cycle
    codes, _, _ = adc_codes(scene, rx)
    assert codes.dtype == np.int16
    got = det.process(wire(Frame.of(codes, cycles=3), 1), wire(Frame.of(rho, cycles=3), 1)).header["per_cycle"]
    lsb = scene.adc_full_scale / 2 ** (scene.adc_bits - 1)
    exact = detect(codes.astype(np.float64) * lsb, rho, scene.sigma_n, 1.5)   # float64 samples: no rounding
    np.testing.assert_allclose(got["q"], exact.q, rtol=1e-13)
    assert got["alarm"] == exact.alarm.tolist() == [False, False, True]


def test_estimator_refuses_frames_without_the_gates_clean_verdict():
    est = RangeEstimator()
    est.start()
    out = est.process(adc_frame(1, cycles=2))
    assert out.header["refused"] is True and est.summary() == {"refused": 2}
    forged = wire(Frame.of(np.zeros((1, 64, 1100), np.float32), verdict="clean"), 2)   # no rho: still refused
    assert est.process(forged).header["refused"] is True


def test_attacker_parameters_are_checked_by_model_with_names():
    with pytest.raises(BlockError, match="unknown parameter for attacker 'random'"):
        AttackerBlock(model="random", range_m=30.0)
    with pytest.raises(BlockError, match='fidelity = "waveform"'):
        AttackerBlock(model="secondary_antenna")
    with pytest.raises(BlockError, match="must be one of"):
        AttackerBlock(model="reactiv")
    with pytest.raises(BlockError, match="unknown parameter for attacker 'reactive'"):
        AttackerBlock(model="reactive", range_m=30.0)
    assert AttackerBlock(model="reactive", distance_m=20.0, latency_s=0.0).model_params == {"distance_m": 20.0,
                                                                                          "latency_s": 0.0}
    assert AttackerBlock(model="smart", rarms=2).model_params == {"rarms": 2.0}


def test_csv_sink_writes_one_row_per_cycle_from_per_cycle_and_header_fields(tmp_path):
    from carav_blocks.csv_sink import CsvSink
    sink = CsvSink(path=str(tmp_path / "c.csv"), columns=["attack_active", "reason", "range_m", "method"])
    sink.start()
    est = wire(Frame.of(None, cycles=2, method="ml", per_cycle={"cycle_index": [4, 6], "attack_active": [False, True],
                                                                 "range_m": [[43.0], [None]]}), 1)
    alarm = wire(Frame.of(None, cycles=1, per_cycle={"cycle_index": [5], "reason": ["attack"]}), 1)
    bad = wire(Frame.of(None, cycles=2, per_cycle={"reason": ["attack"]}), 2)   # one value for two cycles
    sink.process(est)
    sink.process(None, alarm)
    sink.process(None, bad)
    sink.finish()
    assert (tmp_path / "c.csv").read_text().splitlines() == [
        "cycle,port,attack_active,reason,range_m,method", "4,estimates,False,,43.0,ml", "6,estimates,True,,,ml",
        "5,alarms,,attack,,", "2,alarms,,,,"]
    assert sink.summary() == {"rows": 4, "malformed_frames": 1}


def front_end(fidelity: str, seed: int = 4, **attack):
    """channel -> attacker -> adc in-process, every frame through the codec: a function of (rho, cycle0, seq)."""
    from carav_blocks.adc_framer import AdcFramer
    from carav_blocks.channel import Channel
    channel, attacker, adc = (Channel(seed=seed, fidelity=fidelity), AttackerBlock(seed=seed, fidelity=fidelity,
                                                                                    **attack), AdcFramer())
    channel.start()
    attacker.start()

    def run(rho, cycle0, seq):
        out = channel.process(wire(Frame.of(rho, cycle=cycle0, cycles=rho.shape[0]), seq))
        rx, air = wire(out["rx"], seq), wire(out["air"], seq)
        attack = wire(attacker.process(air), seq)
        return rx, air, attack, adc.process(rx, attack)
    return run


@pytest.mark.parametrize("fidelity", ["beat", "waveform"])
def test_reactive_attack_gated_at_the_receiver_equals_the_library_bit_for_bit(fidelity):
    from carav_stream.radar.attackers import make_attacker
    from carav_stream.radar.streams import scene_of, seed_streams
    from carav_stream.radar.synth import simulate_cycles
    scene, params = scene_of("table1"), {"rarms": 3.0, "start_cycle": 5, "n_active_cycles": 14}
    run = front_end(fidelity, model="reactive", **params)
    streams, lib_streams = seed_streams(4), seed_streams(4)
    lib_attacker, reported = make_attacker("reactive", scene, **params), []
    for seq, cycle0 in enumerate(range(0, 32, 8)):
        rho = streams.activation.next(8, scene.n_chirps)
        rho[1] = rho[2] = False        # never with a Manchester source: an all-silent cycle, before and while on
        rx, air, attack, frames = run(rho, cycle0, seq)
        lib = simulate_cycles(scene, rho, lib_streams.noise, attacker=lib_attacker, rng_attack=lib_streams.attack,
                              fidelity=fidelity, cycle0=cycle0)
        assert frames.payload.tobytes() == lib.codes.tobytes()
        assert frames.header["per_cycle"]["attack_active"] == lib.attack_active.tolist()
        reported += frames.header["per_cycle"]["attack_active"]
        assert frames.header["per_cycle"]["clipped"] == lib.clipped.tolist()
        np.testing.assert_array_equal(rx.arrays["on_air"], rho)                 # the receiver's view
        assert list(air.arrays) == ["data"] and air.header["air_cycle"] == cycle0 - 1   # the attacker's: unchanged
        on = [5 <= c < 19 for c in range(cycle0, cycle0 + 8)]
        assert attack.header["gate_by_on_air"] is True and attack.header["per_cycle"]["attack_active"] == on
        if any(on):   # its replies to every chirp, once for all cycles (broadcast by the receiver)
            assert attack.payload.shape == (1, scene.n_chirps, scene.n_samples)
            assert sorted(attack.arrays) == (["data", "tail"] if fidelity == "waveform" else ["data"])
        else:
            assert attack.payload is None and not attack.arrays
    # on in cycles 5..18, but it answers nothing in the silent cycles 9, 10, 17 and 18
    assert reported == [5 <= c < 19 and c % 8 not in (1, 2) for c in range(32)]


def test_adc_refuses_a_gated_attack_it_cannot_gate_naming_the_frame():
    from carav_blocks.adc_framer import AdcFramer
    rho = np.tile(RHO, (2, 1))
    rx, _, attack, _ = front_end("beat", model="reactive", rarms=3.0)(rho, 0, 6)
    adc, data = AdcFramer(), rx.payload
    cases = {
        "no on_air in rx": wire(Frame.of(data, cycle=0, cycles=2), 6),
        r"rx's on_air is bool \(2, 32\)": wire(Frame.of(data, cycle=0, cycles=2).derive(
            keep_data=True, arrays={"on_air": rho[:, :32]}), 6),
        r"rx's on_air is uint8 \(2, 64\)": wire(Frame.of(data, cycle=0, cycles=2).derive(
            keep_data=True, arrays={"on_air": rho.view(np.uint8)}), 6),
    }
    for problem, bad_rx in cases.items():
        with pytest.raises(ValueError, match=r"frame seq 6 \(cycles 0..1\): a reactive attack is gated .*" + problem):
            adc.process(bad_rx, attack)
    no_active = wire(Frame.of(attack.payload, cycles=2, gate_by_on_air=True), 6)
    with pytest.raises(ValueError, match="attack_active is None, not one bool per cycle"):
        adc.process(rx, no_active)
    silent_but_on = wire(Frame.of(None, cycles=2, gate_by_on_air=True, per_cycle={"attack_active": [True, False]}), 6)
    with pytest.raises(ValueError, match=r"switched on \(\[True, False\]\) but sends no replies"):
        adc.process(rx, silent_but_on)
    not_a_flag = wire(Frame.of(attack.payload, cycles=2, gate_by_on_air=1, per_cycle={"attack_active": [True] * 2}), 6)
    with pytest.raises(ValueError, match="attack frame seq 6 .* gate_by_on_air 1\\) does not fit"):
        adc.process(rx, not_a_flag)
    ungated = wire(Frame.of(attack.payload, cycles=2, per_cycle={"attack_active": [True] * 2}), 6)   # flag lost
    with pytest.raises(ValueError, match=r"attack frame seq 6 .*float32 \(1, 64, 1100\).* does not fit"):
        adc.process(rx, ungated)
    assert adc.process(rx, attack).header["per_cycle"]["attack_active"] == [True, True]


@pytest.mark.parametrize("iq", [False, True])
def test_adc_codes_count_nan_and_inf_inputs_apart_from_clipping(iq):
    from carav_stream.radar.scene import load_scene
    from carav_stream.radar.synth import adc, adc_codes
    scene = load_scene("table1", {"iq": iq})
    dtype = np.complex64 if iq else np.float32
    rx = np.zeros((3, 64, 1100), dtype)
    rx[1, 3, 5] = np.nan
    rx[1, 7, 9] = np.inf
    rx[2, 0, 0] = -np.inf
    rx[2, 0, 1] = 10 * scene.adc_full_scale          # a real clip beside a non-finite sample
    if iq:
        rx[1, 3, 6] = complex(0.0, np.nan)            # Q alone non-finite: one sample
    codes, clipped, nonfinite = adc_codes(scene, rx)
    assert nonfinite.tolist() == [0, 3 if iq else 2, 1] and clipped.tolist() == [0, 0, 1]
    assert codes.dtype == np.int16 and codes[1, 3, 5].tolist() == ([0, 0] if iq else 0)
    frames, _ = adc(scene, rx)                        # the float path keeps them visible
    assert np.isnan(frames[1, 3, 5]) and np.isnan(frames[2, 0, 0]) and np.isfinite(frames[0]).all()


def test_detector_judges_invalid_a_cycle_with_nonfinite_adc_input_or_an_unbalanced_rho():
    from carav_stream.radar.synth import adc_codes
    scene = scene_of_table1()
    rx = np.random.default_rng(4).normal(0, scene.sigma_n, (4, 64, 1100)).astype(np.float32)
    rx[1, 2, 3] = np.nan
    codes, _, nonfinite = adc_codes(scene, rx)
    rho = np.zeros((4, 64), bool)
    rho[:, ::2] = True
    rho[3, 1] = True                                   # 33 active chirps: not made by the source
    frame = wire(Frame.of(codes, cycles=4, per_cycle={"nonfinite": nonfinite.tolist()}), 5)
    per = RmsDetector(eta=1.5).process(frame, wire(Frame.of(rho, cycles=4), 5)).header["per_cycle"]
    assert per["invalid"] == [False, True, False, True] and per["alarm"] == [False, True, False, True]
    assert per["raised_by"][1] == "invalid" and per["raised_by"][3] == "bad_rho"
    garbled = wire(Frame.of(codes, cycles=4, per_cycle={"nonfinite": ["0", 0, 0, 0]}), 6)
    assert RmsDetector(eta=1.5).process(garbled, wire(Frame.of(rho, cycles=4), 6)).header["per_cycle"]["invalid"] == [True] * 4
    out = Gate().process(frame, wire(Frame.of(rho, cycles=4, per_cycle=per), 5))
    assert out["clean"].header["per_cycle"]["cycle_index"] == [5, 7]
    assert out["alarms"].header["per_cycle"]["reason"] == ["invalid", "invalid"]


def scene_of_table1():
    from carav_stream.radar.streams import scene_of
    return scene_of("table1")


def test_a_restarted_or_swapped_in_seeded_block_draws_fresh_streams_never_a_replay():
    """Block.instance (incarnation, generation) (0, 0) draws the library's streams; any other instance of the same
    seed draws independent ones, in the source, the channel and the attacker alike."""
    from carav_blocks.channel import Channel
    from carav_blocks.chirp_source import ChirpSource
    from carav_stream.radar.streams import seed_streams

    def draws(instance):
        src, ch, att = ChirpSource(seed=9, batch=4), Channel(seed=9), AttackerBlock(seed=9, model="random", rarms=2.0)
        for b in (src, ch, att):
            b.instance = instance
            b.start()
        src.cycle_budget = None
        rho = src.generate(0)["tx"].payload.copy()
        same = Frame.of(np.arange(256).reshape(4, 64) % 3 == 0, cycle=0, cycles=4)   # one input for every instance
        rx = ch.process(wire(same, 0))
        attack = att.process(wire(rx["air"], 0))
        return rho, rx["rx"].payload.copy(), attack.payload.copy()

    first = draws((0, 0))
    lib = seed_streams(9)
    np.testing.assert_array_equal(first[0], lib.activation.next(4, 64))     # instance (0, 0) is the library's
    for other in ((1, 0), (0, 1), (2, 3)):
        again = draws(other)
        for a, b in zip(first, again):
            assert not np.array_equal(a, b), other
    for a, b in zip(draws((1, 0)), draws((1, 0))):                           # and still reproducible
        np.testing.assert_array_equal(a, b)
