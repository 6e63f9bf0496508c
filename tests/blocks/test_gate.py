"""gate against a table of verdicts (which cycles pass, which are refused and why), in one frame and split."""
import numpy as np
import pytest

from carav_blocks.gate import Gate
from carav_stream.frames import Frame
from tests.blocks import jig

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
