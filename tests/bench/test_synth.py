"""python3 dev.py bench synth: runs, prints a table and writes one JSON record per case (not a timing test)."""
import argparse
import json
import math

import pytest

from bench import records as bench_records
from bench import synth as bench_synth
from carav_stream.radar.scene_loader import load_scene


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
    printed = capsys.readouterr().out
    assert "secondary_antenna" in printed
    stages = [r for r in json.loads(out.read_text())["records"] if r["bench"] == "synth_stage"]
    assert {r["stage"] for r in stages} == {"noise", "echo", "adc", "total"}
    # the machine it measured, SIMD width included, heads the output
    assert printed.startswith("machine: ") and f"({bench_records.machine()['simd']})" in printed.splitlines()[0]
    assert "stage   us/cycle  ns/sample  bound ns/sample  x bound" in printed


def finite_positive(*xs: float) -> bool:
    return all(isinstance(x, float) and math.isfinite(x) and x > 0 for x in xs)


@pytest.mark.parametrize("iq", [False, True])
def test_every_stage_is_given_per_real_value_beside_a_bound_measured_with_it(iq):
    stages = bench_synth.time_stages("awr1642", iq, repeats=1)
    values = 128 * 256 * (2 if iq else 1)                     # awr1642: 128 chirps x 256 samples, I and Q counted
    assert [r["stage"] for r in stages] == ["noise", "echo", "adc", "total"]
    for r in stages:
        assert r["real_values_per_cycle"] == values and r["per"] == ("real value (I or Q)" if iq else "sample")
        assert finite_positive(r["ns_per_sample"], r["bound_ns_per_sample"], r["x_bound"],
                               r["bound_time_per_cycle_s"]), r
        assert r["ns_per_sample"] == pytest.approx(r["time_per_cycle_s"] / values * 1e9, rel=1e-12)
        assert r["bound_ns_per_sample"] == pytest.approx(r["bound_time_per_cycle_s"] / values * 1e9, rel=1e-12)
        assert r["x_bound"] == pytest.approx(r["ns_per_sample"] / r["bound_ns_per_sample"], rel=1e-12)
        assert r["bound"]
    total = {r["stage"]: r["bound_time_per_cycle_s"] for r in stages}
    assert total["total"] == pytest.approx(total["noise"] + total["echo"] + total["adc"], rel=1e-12)


def test_the_bounds_are_timed_on_the_scene_they_bound():
    """A scene with twice the samples costs each bound more time per cycle: the bounds are not fixed figures."""
    small, large = (bench_synth.stage_bounds(load_scene("awr1642", {"iq": iq}), repeats=5) for iq in (False, True))
    assert set(small) == set(large) == {"noise", "echo", "adc"}
    for stage in small:
        assert finite_positive(small[stage][0], large[stage][0])
    assert sum(t for t, _ in large.values()) > sum(t for t, _ in small.values())
