"""Frames of several receivers through the blocks: the front end equals the library bit for bit, the detector takes a
chirp's RMS over all its receivers, the gate passes them, ranging reads receiver 0 in each loop's first slot."""
import numpy as np
import pytest

from carav_blocks.chirp_source import ChirpSource
from carav_blocks.gate import Gate
from carav_blocks.range_estimator import RangeEstimator
from carav_blocks.rms_detector import RmsDetector
from carav_stream.detect.detector import detect_from_rms
from carav_stream.estimate.estimators import estimate
from carav_stream.radar.adc import adc_step, from_codes
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of, seed_streams
from carav_stream.radar.synth import simulate_cycles
from carav_stream.runtime import Frame
from carav_stream.testing.harness import wire
from tests.blocks.helpers import front_end

SCENE = "awr1642_mimo"       # 2 TX x 4 RX, TDM, I-only, 16-bit ADC


@pytest.mark.parametrize("fidelity, attack", [
    ("beat", {"model": "smart", "rarms": 3.0, "start_cycle": 2}),
    ("beat", {"model": "reactive", "rarms": 3.0, "distance_m": 25.0}),
    ("waveform", {"model": "secondary_antenna", "range_m": 30.0, "tx_power_w": 1e-2, "start_cycle": 1}),
])
def test_the_array_front_end_through_the_blocks_equals_the_library_bit_for_bit(fidelity, attack):
    scene = scene_of(SCENE)
    params = {k: v for k, v in attack.items() if k != "model"}
    run = front_end(fidelity, scene=SCENE, azimuth_deg=-30.0, **attack)
    streams, lib = seed_streams(4), seed_streams(4)
    lib_attacker = make_attacker(attack["model"], scene, azimuth_deg=-30.0, **params)
    for seq, cycle0 in enumerate((0, 2)):
        rho = streams.activation.next(2, scene.n_chirps, scene.n_slots)
        rx, _, sent, frames = run(rho, cycle0, seq)
        want = simulate_cycles(scene, rho, lib.noise, attacker=lib_attacker, rng_attack=lib.attack,
                               fidelity=fidelity, cycle0=cycle0)
        assert rx.payload.shape == (2, 4, 128, 256) and frames.payload.dtype == np.int16
        assert frames.payload.tobytes() == want.codes.tobytes()
        assert frames.header["per_cycle"]["clipped"] == want.clipped.tolist()
        assert frames.header["per_cycle"]["attack_active"] == want.attack_active.tolist()
        if sent.payload is not None:      # the attack as the receivers get it: one receiver axis of 4
            assert sent.payload.ndim == 4 and sent.payload.shape[1] == 4


def test_the_source_draws_per_tdm_loop():
    src = ChirpSource(scene=SCENE, seed=9, batch=4)
    src.start()
    rho = src.generate(0)["rho"].payload
    loops = rho.reshape(4, 64, 2)
    assert (loops[..., 0] == loops[..., 1]).all() and (loops[..., 0].sum(axis=1) == 32).all()


def array_cycles(n=3, attack_from=2):
    scene = scene_of(SCENE)
    streams = seed_streams(11)
    rho = streams.activation.next(n, scene.n_chirps, scene.n_slots)
    attacker = make_attacker("smart", scene, azimuth_deg=25.0, rarms=3.0, start_cycle=attack_from)
    return scene, rho, simulate_cycles(scene, rho, streams.noise, attacker=attacker, rng_attack=streams.attack)


def test_the_detector_takes_a_chirps_rms_over_all_its_receivers():
    scene, rho, cyc = array_cycles()
    det = RmsDetector(scene=SCENE, eta=1.5)
    per = det.process(wire(Frame.of(cyc.codes, cycles=3), 1), wire(Frame.of(rho, cycles=3), 1)).header["per_cycle"]
    x = cyc.codes.astype(np.float64) * adc_step(scene)
    combined = np.sqrt(np.mean(x ** 2, axis=(1, 3)))                 # over receivers and samples
    want = detect_from_rms(combined, rho, scene.sigma_n, 1.5)
    np.testing.assert_allclose(per["q"], want.q, rtol=1e-12)
    assert per["alarm"] == want.alarm.tolist() == [False, False, True]
    lone = det.unpaired("frames", wire(Frame.of(cyc.codes, cycles=3), 2))
    assert lone.payload.shape == (3, 128) and lone.header["per_cycle"]["alarm"] == [True] * 3
    with pytest.raises(ValueError, match=r"frames int16 \(3, 128, 256\) and rho \(3, 128\) do not"):
        det.process(wire(Frame.of(cyc.codes[:, 0], cycles=3), 3), wire(Frame.of(rho, cycles=3), 3))


def test_the_gate_passes_array_frames_of_the_clean_cycles():
    scene, rho, cyc = array_cycles()
    frames = wire(Frame.of(cyc.codes, cycles=3), 1)
    verdict = RmsDetector(scene=SCENE, eta=1.5).process(frames, wire(Frame.of(rho, cycles=3), 1))
    out = Gate().process(frames, wire(verdict, 1))
    assert out["clean"].payload.shape == (2, 4, 128, 256) and out["clean"].arrays["rho"].shape == (2, 128)
    np.testing.assert_array_equal(out["clean"].payload, cyc.codes[:2])
    assert out["alarms"].header["per_cycle"]["reason"] == ["attack"]


@pytest.mark.parametrize("method", ["ml", "fft_peak"])
def test_ranging_reads_receiver_zero_in_each_loops_first_slot(method):
    scene, rho, cyc = array_cycles(n=2, attack_from=5)
    est = RangeEstimator(scene=SCENE, method=method)
    est.start()
    frame = Frame.of(cyc.codes, cycles=2, verdict="clean").derive(keep_data=True, arrays={"rho": rho})
    per = est.process(wire(frame, 1)).header["per_cycle"]
    one = scene_of("awr1642")      # the same radar with one antenna: chirps one loop apart, velocity per loop
    want = estimate(np.ascontiguousarray(cyc.codes[:, 0, 0::2]), rho[:, 0::2], est.geometry, method=method,
                    lsb=adc_step(scene))
    assert est.geometry.t_chirp_s == 2 * one.t_chirp_s
    np.testing.assert_allclose(np.array(per["range_m"]), want.range_m)
    np.testing.assert_allclose(np.array(per["velocity_mps"]), want.velocity_mps)
    target = scene.targets[0]
    assert np.allclose(per["range_m"], target.range_m, atol=0.2)
    assert np.allclose(per["velocity_mps"], scene.range_rate_mps(target), atol=0.1)
    samples = Frame.of(from_codes(scene, cyc.codes), cycles=2, verdict="clean").derive(keep_data=True,
                                                                                       arrays={"rho": rho})
    assert est.process(wire(samples, 2)).header["per_cycle"]["range_m"] == per["range_m"]
    with pytest.raises(ValueError, match=r"frame seq 3: 2 cycles, frames \(2, 128, 256\) and rho \(2, 128\) disagree"):
        est.process(wire(Frame.of(cyc.codes[:, 0], cycles=2, verdict="clean").derive(
            keep_data=True, arrays={"rho": rho}), 3))
