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


def adc_frame(seq: int, value: float = 1e-4) -> Frame:
    return wire(Frame.of(np.full((64, 1100), value, np.float32)), seq)


verdict_fields = st.fixed_dictionaries({}, optional={
    "alarm": st.one_of(st.booleans(), st.none(), st.integers(0, 1)),
    "invalid": st.one_of(st.booleans(), st.none(), st.integers(0, 1)),
    "q": st.floats(allow_nan=True), "eta": st.floats(0.1, 3)})


@settings(max_examples=100)
@given(fields=verdict_fields)
def test_gate_never_passes_a_cycle_without_an_explicit_clean_verdict(fields):
    gate = Gate()
    rho = np.zeros(64, bool)
    rho[::2] = True
    out = gate.process(adc_frame(3), wire(Frame.of(rho, **fields), 3))
    clean = fields.get("alarm") is False and fields.get("invalid") is False
    assert ("clean" in out) == clean and ("alarms" in out) == (not clean)
    if clean:
        assert out["clean"].header["verdict"] == "clean"
        np.testing.assert_array_equal(out["clean"].arrays["rho"], rho)


def test_gate_refuses_cycle_without_verdict_and_verdict_without_frame():
    gate = Gate()
    out = gate.unpaired("frames", adc_frame(7))
    assert set(out) == {"alarms"} and out["alarms"].header["reason"] == "no_verdict"
    assert out["alarms"].payload is None
    out = gate.unpaired("verdict", wire(Frame.of(np.ones(64, bool), alarm=False, invalid=False), 8))
    assert out["alarms"].header["reason"] == "no_frame"


def test_detector_flags_nan_frames_and_frames_without_rho():
    det = RmsDetector(eta=1.5)
    rho = np.zeros(64, bool)
    rho[:32] = True
    frames = np.random.default_rng(0).normal(0, det.sigma, (64, 1100)).astype(np.float32)
    ok = det.process(wire(Frame.of(frames), 1), wire(Frame.of(rho), 1))
    assert ok.header["alarm"] is False and ok.header["q"] < 1.5
    frames[5, 7] = np.nan
    bad = det.process(wire(Frame.of(frames), 2), wire(Frame.of(rho), 2))
    assert bad.header["alarm"] is True and bad.header["invalid"] is True and bad.header["raised_by"] == "invalid"
    lone = det.unpaired("frames", wire(Frame.of(frames), 3))
    assert lone.header["alarm"] is True and lone.header["reason"] == "no_rho"
    assert det.unpaired("rho", wire(Frame.of(rho), 4)) is None


def test_estimator_refuses_frames_without_the_gates_clean_verdict():
    est = RangeEstimator()
    est.start()
    out = est.process(adc_frame(1))
    assert out.header["refused"] is True and est.summary() == {"refused": 1}
    forged = wire(Frame.of(np.zeros((64, 1100), np.float32), verdict="clean"), 2)   # no rho: still refused
    assert est.process(forged).header["refused"] is True


def test_attacker_parameters_are_checked_by_model_with_names():
    with pytest.raises(BlockError, match="unknown parameter for attacker 'random'"):
        AttackerBlock(model="random", range_m=30.0)
    with pytest.raises(BlockError, match='fidelity = "waveform"'):
        AttackerBlock(model="secondary_antenna")
    with pytest.raises(BlockError, match="must be one of"):
        AttackerBlock(model="reactive")
    assert AttackerBlock(model="smart", rarms=2).model_params == {"rarms": 2.0}
