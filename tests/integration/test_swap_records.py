"""Swaps on a running radar graph leave a record a reader can follow: the reply names the model and the parameters
set, `carav status` and the run's summary list every applied swap with its model, parameters and time, and every
refused swap with the parameters asked and the reason."""
import json
import re
from pathlib import Path

import pytest

from tests.integration.conftest import PACED, wait_until

pytestmark = pytest.mark.integration
TAPS = Path(__file__).resolve().parent / "graphs" / "radar_taps.toml"


def status_of(carav) -> dict:
    done = carav.cli("status", "--json")
    assert done.returncode == 0, done.stderr
    runs = json.loads(done.stdout, parse_constant=lambda word: pytest.fail(f"status --json printed {word}"))
    return runs[0] if runs else {}


def test_applied_and_refused_swaps_are_named_with_their_model_in_reply_status_and_summary(carav):
    run = carav.run(TAPS, "--cycles", "0", "--set", "batch=4", *PACED)
    wait_until(lambda: status_of(carav).get("cycles", 0) > 40, "cycles before the swaps", *carav.started)
    refused = carav.cli("swap", "attacker", "attacker", "--set", "model=smart", "--set", "rarms=-3")
    assert refused.returncode == 3 and "rarms" in refused.stderr, refused.stderr
    not_a_number = carav.cli("swap", "attacker", "attacker", "--set", "model=smart", "--set", "rarms=nan")
    assert not_a_number.returncode == 3 and "rarms" in not_a_number.stderr, not_a_number.stderr
    done = carav.cli("swap", "attacker", "attacker", "--set", "model=smart", "--set", "rarms=3")
    assert done.returncode == 0, done.stderr
    assert re.match(r"attacker: now attacker@1#1 \(smart, rarms=3\) from cycle (\d+) \(frame seq (\d+)\)$",
                    done.stdout.strip()), done.stdout
    first_cycle = int(re.search(r"from cycle (\d+)", done.stdout)[1])
    s = status_of(carav)
    (applied,), (no, nan) = s["swaps"], s["refused_swaps"]
    assert applied["params"]["model"] == "smart" and applied["params"]["rarms"] == 3 and applied["at_s"] > 0
    assert no["node"] == "attacker" and no["asked"] == {"model": "smart", "rarms": -3} and "rarms" in no["error"]
    assert nan["asked"] == {"model": "smart", "rarms": "nan"} and "rarms" in nan["error"]   # JSON has no NaN
    text = carav.cli("status").stdout
    assert f"swap: node attacker runs block attacker (version 1) (smart, rarms=3) from cycle {first_cycle} (frame seq" \
        in text, text
    assert applied["first_cycle"] == first_cycle > 40      # the swap came after the 40 cycles waited for
    assert "swap refused: node attacker to block attacker (smart, rarms=-3) at " in text, text
    assert carav.cli("stop").returncode == 0
    assert run.wait() == 0, run.stderr()
    summary = run.summary()
    assert summary["swaps"] == [applied] and summary["refused_swaps"] == [no, nan]
    assert "swap refused: node attacker to block attacker (smart, rarms=-3) at " in run.stdout()
