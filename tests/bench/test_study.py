"""`python3 dev.py bench study`: a record with both worker counts, the scheduler's overhead and the rare-event check."""
import json

import pytest

from bench import main as run_bench

pytestmark = pytest.mark.integration
pytest.importorskip("distributed")


def test_bench_study_writes_its_record(tmp_path):
    out = tmp_path / "study.json"
    assert run_bench(["study", "--repeats", "1", "--trials", "30", "--tasks", "20", "--rare-cycles", "400000",
                  "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["command"] == "python3 dev.py bench study --repeats 1 --trials 30 --tasks 20 --rare-cycles 400000"
    (r,) = doc["records"]
    assert r["cycles"] == 30 * 12 and set(r["cycles_per_s"]) == {"1", "2"} and r["overhead_s_per_task"] > 0
    assert r["speedup_2_over_1"] == r["runs_speedup"][0] > 0
    assert r["rare_cycles"] == 400000 and 0 <= r["rare_pf_lo"] <= r["rare_pf"] <= r["rare_pf_hi"] <= 1
    assert r["rare_pf_closed_form"] == pytest.approx(1e-6, rel=1e-9)
    assert r["rare_agrees"] == (r["rare_pf_lo"] <= r["rare_pf_closed_form"] <= r["rare_pf_hi"])
