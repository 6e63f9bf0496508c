"""rms_detector against golden vectors written from the paper's Section V.A, its properties and its refusals."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.gate import Gate
from carav_blocks.rms_detector import RmsDetector
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.block import BlockError
from carav_stream.runtime.frames import Frame
from tests.blocks import jig
from tests.blocks.helpers import SCENE, wire

VECTORS = jig.vectors("rms_detector")
TABLE1 = scene_of(SCENE)
LSB = TABLE1.adc_full_scale / 2 ** (TABLE1.adc_bits - 1)


def extract(out: dict[str, Frame], n: int) -> dict[str, np.ndarray]:
    verdict = out["verdict"]
    per = verdict.header["per_cycle"]
    got = {name: np.array(per[name]) for name in ("q", "c", "alarm", "invalid", "raised_by", "k_max", "rbar")}
    return {"verdict": verdict.payload, **got}


@pytest.mark.parametrize("name", list(VECTORS))
def test_detector_matches_the_papers_equations_in_one_frame_and_split(name):
    jig.check_vector(RmsDetector, VECTORS[name], extract)


def test_detector_golden_vectors_are_what_their_generator_writes():
    jig.check_generator_reproduces("rms_detector")


def test_detector_golden_vectors_cover_clean_random_smart_d1_and_clipped_cycles():
    alarms = {name: v["outputs"]["alarm"].tolist() for name, v in VECTORS.items()}
    assert alarms == {"no_attack": [False, False], "attacks": [True, True, True], "eta2_clipped": [False, True]}
    assert VECTORS["attacks"]["outputs"]["raised_by"].tolist() == ["D0", "D0", "D1"]
    assert 1.5 < VECTORS["eta2_clipped"]["outputs"]["q"][0] < 2.0          # an alarm at 1.5, not at eta 2
    assert np.count_nonzero(np.abs(VECTORS["eta2_clipped"]["inputs"]["frames"][1]) >= 2047) > 10_000


def rho_rows(draw_bits: list[int]) -> np.ndarray:
    order = np.argsort(np.array(draw_bits, dtype=np.int64), kind="stable")
    rho = np.zeros(64, bool)
    rho[order[:32]] = True
    return rho


@pytest.mark.slow
@settings(max_examples=25)
@given(code=st.integers(1, 2047), signs=st.lists(st.booleans(), min_size=1100, max_size=1100),
       keys=st.lists(st.integers(0, 2 ** 16), min_size=64, max_size=64), eta=st.floats(0.5, 3.0))
def test_detector_rms_of_a_constant_modulus_signal_equals_its_amplitude(code, signs, keys, eta):
    codes = np.where(np.array(signs), code, -code).astype(np.int16)
    frame = np.broadcast_to(codes, (1, 64, 1100))
    rho = rho_rows(keys)[None]
    out = RmsDetector(scene=SCENE, eta=eta).process(jig.wire(Frame.of(frame, cycles=1), 1),
                                                    jig.wire(Frame.of(rho, cycles=1), 1))
    per = out.header["per_cycle"]
    amplitude = code * LSB
    assert per["rbar"][0] == pytest.approx(amplitude, rel=1e-12)          # every active chirp's RMS
    assert per["q"][0] == pytest.approx(amplitude / TABLE1.sigma_n, rel=1e-12)   # D1 = 0, D0 = amplitude / sigma_n
    assert per["raised_by"] == ["D0"] and per["alarm"] == [amplitude / TABLE1.sigma_n / eta >= 1]


def test_detector_judges_invalid_a_cycle_whose_rho_has_no_silent_chirp():
    # The paper's rho is balanced (Algorithm 1, step 1); an all-active row was not made by the source: the
    # cycle gets an invalid alarm verdict (fail closed), the other cycle of the frame is judged as usual
    codes = np.zeros((2, 64, 1100), np.int16)
    rho = np.zeros((2, 64), bool)
    rho[0, :32] = True
    rho[1] = True
    per = RmsDetector(scene=SCENE).process(jig.wire(Frame.of(codes, cycles=2), 5),
                                jig.wire(Frame.of(rho, cycles=2), 5)).header["per_cycle"]
    assert per["invalid"] == [False, True] and per["alarm"] == [False, True]
    assert per["raised_by"][1] == "bad_rho" and per["q"][1] == float("inf")


def test_detector_refuses_frames_and_rho_of_different_cycles_naming_both():
    codes = np.zeros((2, 64, 1100), np.int16)
    rho = np.tile(rho_rows(list(range(64))), (3, 1))
    with pytest.raises(ValueError, match=r"frame seq 4: frames int16 \(2, 64, 1100\) and rho \(3, 64\) do not"):
        RmsDetector(scene=SCENE).process(jig.wire(Frame.of(codes, cycles=2), 4), jig.wire(Frame.of(rho, cycles=3), 4))


@pytest.mark.parametrize("eta", [0.0, -1.0])
def test_detector_refuses_a_threshold_that_is_not_positive_naming_eta(eta):
    with pytest.raises(BlockError, match=rf"eta: must be > 0, got {eta:g}"):
        RmsDetector(scene=SCENE, eta=eta)


def test_detector_flags_nan_frames_and_frames_without_rho():
    det = RmsDetector(scene=SCENE, eta=1.5)
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
    from carav_stream.radar.adc import adc_codes
    from carav_stream.radar.streams import scene_of
    scene = scene_of("table1")
    det = RmsDetector(scene=SCENE, eta=1.5)
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


def test_detector_judges_invalid_a_cycle_with_nonfinite_adc_input_or_an_unbalanced_rho():
    from carav_stream.radar.adc import adc_codes
    scene = scene_of(SCENE)
    rx = np.random.default_rng(4).normal(0, scene.sigma_n, (4, 64, 1100)).astype(np.float32)
    rx[1, 2, 3] = np.nan
    codes, _, nonfinite = adc_codes(scene, rx)
    rho = np.zeros((4, 64), bool)
    rho[:, ::2] = True
    rho[3, 1] = True                                   # 33 active chirps: not made by the source
    frame = wire(Frame.of(codes, cycles=4, per_cycle={"nonfinite": nonfinite.tolist()}), 5)
    per = RmsDetector(scene=SCENE, eta=1.5).process(frame, wire(Frame.of(rho, cycles=4), 5)).header["per_cycle"]
    assert per["invalid"] == [False, True, False, True] and per["alarm"] == [False, True, False, True]
    assert per["raised_by"][1] == "invalid" and per["raised_by"][3] == "bad_rho"
    garbled = wire(Frame.of(codes, cycles=4, per_cycle={"nonfinite": ["0", 0, 0, 0]}), 6)
    verdict = RmsDetector(scene=SCENE, eta=1.5).process(garbled, wire(Frame.of(rho, cycles=4), 6))
    assert verdict.header["per_cycle"]["invalid"] == [True] * 4
    out = Gate().process(frame, wire(Frame.of(rho, cycles=4, per_cycle=per), 5))
    assert out["clean"].header["per_cycle"]["cycle_index"] == [5, 7]
    assert out["alarms"].header["per_cycle"]["reason"] == ["invalid", "invalid"]


@pytest.mark.parametrize("codes", [False, True])
def test_detector_judges_a_receiver_arrays_frames_on_each_chirps_rms_over_all_receivers(codes, tmp_path):
    """Frames (cycles, n_rx, chirps, samples) of a four-receiver table1, float32 samples or int16 codes: the verdict
    is detect(receivers=True) on the same numbers; the gate passes the clean cycles' 4-D frames whole; a lone frame
    gets its cycles' rho; a one-receiver scene refuses them."""
    from carav_stream.detect.detector import detect
    from carav_stream.radar.adc import adc_codes
    from carav_stream.radar.scene_loader import PRESET_DIR
    array = tmp_path / "table1_4rx.toml"
    array.write_text((PRESET_DIR / "table1.toml").read_text().replace("[[targets]]", "n_rx = 4\n\n[[targets]]", 1))
    det = RmsDetector(scene=str(array), eta=1.5)
    assert det.sigma == RmsDetector(scene=SCENE, eta=1.5).sigma
    rng = np.random.default_rng(7)
    rho = np.zeros((3, 64), bool)
    rho[:, ::2] = True
    rx = rng.normal(0, det.sigma, (3, 4, 64, 1100)).astype(np.float32)
    rx[1, 2, 5] *= 4                                           # one receiver of a silent chirp: cycle 1 alarms
    x = adc_codes(TABLE1, rx)[0] if codes else rx
    out = det.process(wire(Frame.of(x, cycles=3), 1), wire(Frame.of(rho, cycles=3), 1))
    per = out.header["per_cycle"]
    samples = x.astype(np.float64) * LSB if codes else x
    exact = detect(samples, rho, det.sigma, 1.5, receivers=True)
    np.testing.assert_allclose(per["q"], exact.q, rtol=1e-6)
    assert per["alarm"] == exact.alarm.tolist() == [False, True, False] and per["raised_by"][1] == "D0"
    assert np.array_equal(out.payload, rho)
    gated = Gate().process(wire(Frame.of(x, cycles=3), 1), wire(out, 1))
    assert gated["clean"].payload.shape == (2, 4, 64, 1100) and np.array_equal(gated["clean"].payload, x[[0, 2]])
    assert gated["alarms"].header["per_cycle"]["reason"] == ["attack"]
    lone = det.unpaired("frames", wire(Frame.of(x, cycles=3), 2))
    assert lone.payload.shape == (3, 64) and lone.header["per_cycle"]["invalid"] == [True] * 3
    with pytest.raises(ValueError, match="do not describe the same cycles"):
        RmsDetector(scene=SCENE, eta=1.5).process(wire(Frame.of(x, cycles=3), 3), wire(Frame.of(rho, cycles=3), 3))
