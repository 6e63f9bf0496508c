"""range_estimator against planted point targets (closed-form beat signals), and its refusals."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.range_estimator import RangeEstimator
from carav_stream.runtime.block import BlockError
from carav_stream.runtime.frames import Frame
from tests.blocks import jig
from tests.blocks.helpers import SCENE, adc_frame, wire

VECTORS = jig.vectors("range_estimator")


def extract(out: dict[str, Frame], n: int) -> dict[str, np.ndarray]:
    per = out["estimates"].header["per_cycle"]
    assert out["estimates"].header.get("refused") is None
    return {name: np.array(per[name], dtype=np.float64) for name in ("range_m", "velocity_mps")}


@pytest.mark.parametrize("name", list(VECTORS))
def test_estimator_recovers_planted_targets_in_one_frame_and_split(name):
    jig.check_vector(RangeEstimator, VECTORS[name], extract)


def test_estimator_golden_vectors_are_what_their_generator_writes():
    jig.check_generator_reproduces("range_estimator")


@settings(max_examples=10)
@given(range_m=st.floats(5.0, 400.0), velocity_mps=st.floats(-60.0, 60.0), seed=st.integers(0, 2 ** 16))
def test_fft_peak_recovers_a_planted_target_within_one_range_bin(range_m, velocity_mps, seed):
    make = jig.load_generator("range_estimator")
    make.TARGETS = [(range_m, velocity_mps)]    # this module object is private to the test
    codes, rho = make.cycles(seed, 300.0, 40.0)
    frame = Frame.of(codes, cycle=0, cycles=1, verdict="clean").derive(keep_data=True, arrays={"rho": rho})
    est = RangeEstimator(method="fft_peak", scene=str(jig.GOLDEN / make.SCENE_FILE))
    est.start()
    got = est.process(jig.wire(frame, 1)).header["per_cycle"]["range_m"][0][0]
    assert abs(got - range_m) <= make.RANGE_BIN_M, (got, range_m, make.RANGE_BIN_M)


def test_estimator_refuses_an_unknown_method_naming_the_choices():
    with pytest.raises(BlockError, match=r"method: must be one of \['fft_peak', .*'ml'\], got 'fft'"):
        RangeEstimator(scene=SCENE, method="fft")


def test_estimator_refuses_frames_without_the_gates_clean_verdict():
    est = RangeEstimator(scene=SCENE)
    est.start()
    out = est.process(adc_frame(1, cycles=2))
    assert out.header["refused"] is True and est.summary() == {"refused": 2}
    forged = wire(Frame.of(np.zeros((1, 64, 1100), np.float32), verdict="clean"), 2)   # no rho: still refused
    assert est.process(forged).header["refused"] is True
