"""`python3 dev.py bench view`: the graph alone, with the live view node, and with a browser on the page, in one
record."""
import json

import pytest

from bench import browser
from bench import main as run_bench
from bench.report import view_rows

pytestmark = pytest.mark.integration


def test_bench_view_writes_its_record_and_its_rows(tmp_path):
    out = tmp_path / "view.json"
    assert run_bench(["view", "--repeats", "1", "--cycles", "640", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["command"] == "python3 dev.py bench view --repeats 1 --cycles 640"
    (r,) = doc["records"]
    assert r["cycles"] == 640 and r["graph"]["view_frames"] == [0]
    # 20 frames of 32 cycles: the first 10 clean (gate.clean and ranging.estimates), the last 10 under the smart
    # attack at RARMS 3 (seed 5: every cycle alarmed, gate.alarms only); every one reached the view or was skipped
    assert r["view"]["view_frames"][0] + r["view"]["skipped_by_taps"][0] == 2 * 10 + 10
    assert r["view"]["ratio_to_graph"] == r["view"]["runs_ratio"][0] > 0
    if browser.missing():
        assert "view_browser" not in r and r["browser"].startswith("skipped")
    else:
        assert r["view_browser"]["ratio_to_graph"] > 0 and r["browser"] == "headless chromium"
    rows = view_rows(doc)
    assert rows[0][2] == ">= 0.9 x" and rows[0][3] == ("yes" if r["view"]["ratio_to_graph"] >= 0.9 else "**no**")
