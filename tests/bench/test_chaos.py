"""`python3 dev.py bench chaos`: the checks it makes of the logs, and a short run of it on real processes."""
import json

import pytest

from bench import main as run_bench
from bench.chaos import check_logs, met


def frame(cycle, n, port=None, **per):
    return {"cycle": cycle, "cycles": n, **({"port": port} if port else {}),
            "per_cycle": {"cycle_index": list(range(cycle, cycle + n)), **per}}


def test_the_log_checks_count_cycles_judged_twice_out_of_order_and_passed_without_a_clean_verdict():
    verdicts = [frame(0, 2, alarm=[False, True]), frame(2, 2, alarm=[False, False])]
    gated = [frame(0, 1, "inp", verdict=["clean"]), frame(1, 1, "extra", verdict=["attack"]),
             frame(2, 2, "inp", verdict=["clean", "clean"])]
    good = check_logs(verdicts, gated)
    assert good == {"verdict_log_cycles": 4, "gated_log_cycles": 4, "passed_to_ranging": 3, "judged_twice": 0,
                    "out_of_order": 0, "clean_without_clean_verdict": 0}
    bad = check_logs(verdicts + [frame(1, 1, alarm=[True])],                       # cycle 1 again, and late
                     [*gated, frame(1, 1, "inp", verdict=["clean"])])               # an alarmed cycle passed
    assert bad["judged_twice"] == 2 and bad["out_of_order"] == 2 and bad["clean_without_clean_verdict"] == 1
    unverified = check_logs(verdicts, [frame(0, 1, "inp", verdict=["no_verdict"])])
    assert unverified["clean_without_clean_verdict"] == 1


def test_a_sink_never_killed_must_have_written_exactly_what_it_was_counted_for():
    r = {"judged_twice": 0, "out_of_order": 0, "clean_without_clean_verdict": 0, "judged_agreement": 0.0,
         "left_processes": 0, "left_files": [],
         "sinks": {"vlog": {"lines": 10, "counted": 9, "killed": 1}, "glog": {"lines": 7, "counted": 7, "killed": 0}}}
    assert all(met(r).values())
    r["sinks"]["glog"]["counted"] = 6
    assert not met(r)["sinks"]
    r["judged_agreement"] = 0.02
    assert not met(r)["judged_agreement"]


@pytest.mark.integration
def test_a_short_chaos_run_kills_nodes_and_finds_nothing_judged_twice_or_left_behind(tmp_path):
    out = tmp_path / "chaos.json"
    run_bench(["chaos", "--seconds", "4", "--every-s", "1", "--transport", "zmq", "--settle-s", "2",
               "--json", str(out)])
    rec = json.loads(out.read_text())["records"][0]
    assert rec["n_kills"] >= 2 and rec["restarts"] >= rec["n_kills"] and rec["cycles"] > 0
    assert rec["judged_twice"] == 0 and rec["out_of_order"] == 0 and rec["clean_without_clean_verdict"] == 0
    assert rec["passed_to_ranging"] > 0 and rec["left_processes"] == 0 and rec["left_files"] == []
