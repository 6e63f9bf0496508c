"""python3 dev.py bench synth: runs, prints a table and writes one JSON record per case (not a timing test)."""
import argparse
import json

from bench import synth as bench_synth


def test_bench_synth_writes_one_record_per_case(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    bench_synth.configure(parser)
    out = tmp_path / "synth.json"
    args = parser.parse_args(["--json", str(out), "--cycles", "1", "--repeats", "1", "--presets", "awr1642"])
    assert bench_synth.run(args) == 0
    records = [r for r in json.loads(out.read_text())["records"] if r["bench"] == "synth"]
    expected = list(bench_synth.cases(["awr1642"], quick=False))
    assert [(r["preset"], r["fidelity"], r["attacker"], r["iq"]) for r in records] == expected
    assert ("awr1642", "waveform", "secondary_antenna", False) in expected
    for r in records:
        assert r["time_per_cycle_s"] > 0 and r["realtime_factor"] > 0
        assert r["radar_cycles_per_s"] == 25.0                 # 40 ms frames
    assert "secondary_antenna" in capsys.readouterr().out
    stages = [r for r in json.loads(out.read_text())["records"] if r["bench"] == "synth_stage"]
    assert {r["stage"] for r in stages} == {"noise", "echo", "adc", "total"}
