"""Golden vectors for blocks/gate.py: a table of verdict fields and what the gate must do with each cycle.

The rule (Algorithm 1, steps 5-6, failing closed): a cycle goes on to ranging only when its verdict says
alarm = false and invalid = false in so many words (booleans); anything else is refused with a reason.
Run `python tests/golden/make_gate.py` to rewrite tests/golden/gate.npz.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import golden_io  # noqa: E402

GENERATOR = "make_gate.py"
INF = float("inf")
TABLE = [   # alarm, invalid, raised_by, q  ->  reason ("" = passed)
    (False, False, "D0", 0.9, ""),
    (True, False, "D0", 3.2, "attack"),
    (True, False, "D1", 1.7, "attack"),
    (False, True, "invalid", INF, "invalid"),
    (True, True, "invalid", INF, "invalid"),
    (True, True, "no_rho", INF, "no_rho"),
    (None, False, "D0", 0.5, "bad_verdict"),     # no alarm value: not clean
    (False, None, "D0", 0.5, "bad_verdict"),     # no invalid value: not clean
    (0, False, "D0", 0.5, "bad_verdict"),        # 0 is not False in so many words
    (False, 0, "D0", 0.5, "bad_verdict"),
    (False, False, "D1", 1.4, ""),
    (1, False, "D0", 2.0, "bad_verdict"),        # an integer alarm is not the boolean True either
]


def build() -> dict[str, dict]:
    rng = np.random.default_rng(41)
    n = len(TABLE)
    frames = rng.integers(-2048, 2048, (n, 4, 8)).astype(np.int16)
    rho = np.array([rng.permutation(4) < 2 for _ in range(n)])
    passed = np.array([row[4] == "" for row in TABLE])
    per = {"alarm": [r[0] for r in TABLE], "invalid": [r[1] for r in TABLE], "raised_by": [r[2] for r in TABLE],
           "q": [r[3] for r in TABLE]}
    description = (f"{n} cycles of 4 chirps x 8 int16 codes, {passed.sum()} clean verdicts, refused: "
                   + ", ".join(sorted({r[4] for r in TABLE} - {""})))
    return {"table": {
        "args": {}, "description": description, "generator": GENERATOR,
        "inputs": {"frames": frames, "verdict": rho}, "headers": {"verdict": {"eta": 1.5, "per_cycle": per}},
        "outputs": {"passed": passed, "reason": np.array([r[4] for r in TABLE]),
                    "q": np.array([r[3] for r in TABLE], dtype=np.float64),
                    "data": np.where(passed[:, None, None], frames, 0).astype(np.int16),
                    "rho": np.where(passed[:, None], rho, False)}}}


if __name__ == "__main__":
    golden_io.save(golden_io.HERE / "gate.npz", build())
