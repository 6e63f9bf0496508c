"""rms_detector against golden vectors written from the paper's Section V.A, its properties and its refusals."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.rms_detector import RmsDetector
from carav_stream.block import BlockError
from carav_stream.frames import Frame
from carav_stream.radar.streams import scene_of
from tests.blocks import jig

VECTORS = jig.vectors("rms_detector")
SCENE = scene_of("table1")
LSB = SCENE.adc_full_scale / 2 ** (SCENE.adc_bits - 1)


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


@settings(max_examples=25)
@given(code=st.integers(1, 2047), signs=st.lists(st.booleans(), min_size=1100, max_size=1100),
       keys=st.lists(st.integers(0, 2 ** 16), min_size=64, max_size=64), eta=st.floats(0.5, 3.0))
def test_detector_rms_of_a_constant_modulus_signal_equals_its_amplitude(code, signs, keys, eta):
    codes = np.where(np.array(signs), code, -code).astype(np.int16)
    frame = np.broadcast_to(codes, (1, 64, 1100))
    rho = rho_rows(keys)[None]
    out = RmsDetector(eta=eta).process(jig.wire(Frame.of(frame, cycles=1), 1), jig.wire(Frame.of(rho, cycles=1), 1))
    per = out.header["per_cycle"]
    amplitude = code * LSB
    assert per["rbar"][0] == pytest.approx(amplitude, rel=1e-12)          # every active chirp's RMS
    assert per["q"][0] == pytest.approx(amplitude / SCENE.sigma_n, rel=1e-12)   # D1 = 0, D0 = amplitude / sigma_n
    assert per["raised_by"] == ["D0"] and per["alarm"] == [amplitude / SCENE.sigma_n / eta >= 1]


def test_detector_judges_invalid_a_cycle_whose_rho_has_no_silent_chirp():
    # The paper's rho is balanced (Algorithm 1, step 1); an all-active row was not made by the source: the
    # cycle gets an invalid alarm verdict (fail closed), the other cycle of the frame is judged as usual
    codes = np.zeros((2, 64, 1100), np.int16)
    rho = np.zeros((2, 64), bool)
    rho[0, :32] = True
    rho[1] = True
    per = RmsDetector().process(jig.wire(Frame.of(codes, cycles=2), 5),
                                jig.wire(Frame.of(rho, cycles=2), 5)).header["per_cycle"]
    assert per["invalid"] == [False, True] and per["alarm"] == [False, True]
    assert per["raised_by"][1] == "bad_rho" and per["q"][1] == float("inf")


def test_detector_refuses_frames_and_rho_of_different_cycles_naming_both():
    codes = np.zeros((2, 64, 1100), np.int16)
    rho = np.tile(rho_rows(list(range(64))), (3, 1))
    with pytest.raises(ValueError, match=r"frame seq 4: frames int16 \(2, 64, 1100\) and rho \(3, 64\) do not"):
        RmsDetector().process(jig.wire(Frame.of(codes, cycles=2), 4), jig.wire(Frame.of(rho, cycles=3), 4))


@pytest.mark.parametrize("eta", [0.0, -1.0])
def test_detector_refuses_a_threshold_that_is_not_positive_naming_eta(eta):
    with pytest.raises(BlockError, match=rf"eta: must be > 0.0, got {eta}"):
        RmsDetector(eta=eta)
