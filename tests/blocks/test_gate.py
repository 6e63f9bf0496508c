"""gate against a table of verdicts (which cycles pass, which are refused and why), in one frame and split."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.gate import Gate
from carav_stream.runtime.frames import Frame
from tests.blocks import jig
from tests.blocks.helpers import N_S, RHO, adc_frame, wire

VECTORS = jig.vectors("gate")


def extract(out: dict[str, Frame], n: int) -> dict[str, np.ndarray]:
    """Per cycle of the input frame: passed, reason ("" when passed), q, and the clean data and rho (0 if not)."""
    rows: dict[int, tuple] = {}
    if "clean" in out:
        clean = out["clean"]
        assert clean.header["verdict"] == "clean" and clean.header["eta"] == 1.5
        per = clean.header["per_cycle"]
        for i, index in enumerate(per["cycle_index"]):
            rows[index] = (True, "", per["q"][i], clean.payload[i], clean.arrays["rho"][i])
    if "alarms" in out:
        per = out["alarms"].header["per_cycle"]
        assert out["alarms"].header["alarm"] is True
        for i, index in enumerate(per["cycle_index"]):
            assert index not in rows, f"cycle {index} both passed and refused"
            rows[index] = (False, per["reason"][i], per["q"][i], None, None)
    assert len(rows) == n and max(rows) - min(rows) == n - 1, f"cycles {sorted(rows)} for a frame of {n}"
    ordered = [rows[k] for k in sorted(rows)]
    return {"passed": np.array([r[0] for r in ordered]), "reason": np.array([r[1] for r in ordered]),
            "q": np.array([r[2] for r in ordered], dtype=np.float64),
            "data": np.array([r[3] if r[0] else np.zeros((4, 8), np.int16) for r in ordered]),
            "rho": np.array([r[4] if r[0] else np.zeros(4, bool) for r in ordered])}


@pytest.mark.parametrize("name", list(VECTORS))
def test_gate_passes_exactly_the_clean_verdicts_of_the_table_in_one_frame_and_split(name):
    jig.check_vector(Gate, VECTORS[name], extract)


def test_gate_golden_vectors_are_what_their_generator_writes():
    jig.check_generator_reproduces("gate")


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
        assert out["clean"].payload.shape == (len(passed), 64, N_S)
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
