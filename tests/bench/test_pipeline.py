"""`python3 dev.py bench pipeline`: the shipped radar chain graph against run_algorithm1 in one process."""
import argparse
import json
import math
import statistics

import pytest

from bench import main as run_bench
from bench import pipeline
from bench.pipeline import _modes, ceiling, pipeline_overrides, tracker_graph
from carav_graphs import graph_file
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.loader import load_graph


def test_the_benchmark_runs_the_shipped_radar_chain_with_only_its_case_set():
    g = load_graph(graph_file("radar_chain"), pipeline_overrides("awr1642", "waveform", 100, "fft_peak", 8))
    assert g.params == {"scene": "awr1642", "batch": 8, "fidelity": "waveform", "seed": 5}
    assert g.nodes["attacker"].params["model"] == "smart" and g.nodes["attacker"].params["start_cycle"] == 50
    assert g.nodes["ranging"].params["method"] == "fft_peak"
    assert [str(e) for e in g.edges] == [str(e) for e in load_graph(graph_file("radar_chain")).edges]


def test_the_tracker_mode_adds_the_tracks_graphs_tracker_after_the_target_list_and_nothing_else(tmp_path):
    overrides = pipeline_overrides("table1", "beat", 200, "ml", 32)
    chain = load_graph(graph_file("radar_chain"), overrides)
    g = load_graph(tracker_graph(tmp_path), overrides)
    tracks = load_graph(graph_file("table1_tracks"))
    assert set(g.nodes) == set(chain.nodes) | {"tracker"} and g.params == chain.params
    assert {n: node.params for n, node in g.nodes.items() if n != "tracker"} == \
        {n: node.params for n, node in chain.nodes.items()}
    added = {str(e) for e in g.edges} - {str(e) for e in chain.edges}
    assert added == {str(e) for e in tracks.edges if e.dst == "tracker"} == \
        {"ranging.estimates -> tracker.estimates", "gate.alarms -> tracker.alarms"}
    own = {k: v for k, v in g.nodes["tracker"].params.items() if k not in g.params}
    assert own == {k: v for k, v in tracks.nodes["tracker"].params.items() if k not in tracks.params}
    assert g.nodes["tracker"].params["scene"] == "table1"       # the case's scene, not the tracks graph's


def test_on_table1_the_tracker_and_the_pipeline_it_is_paired_with_run_on_table1_following(monkeypatch):
    """table1's car has a range rate its frozen geometry never follows (validation warns): the tracker's paired runs
    take the scene of graphs/table1_tracks.toml, both of them; awr1642 keeps its own, paired with the case's run."""
    calls = []

    def fake(preset, fidelity, n, method, batch, transport, record_to=None, tracker=False):
        calls.append((preset, tracker))
        rate = {("table1", False): 1000.0, ("table1_following", False): 900.0, ("awr1642", False): 50.0}.get(
            (preset, tracker), 800.0 if preset == "table1_following" else 40.0)
        return rate, {"channel": 1.0}, {"tracks": {"born": 1, "deleted": 0}}

    monkeypatch.setattr(pipeline, "_pipeline", fake)
    monkeypatch.setattr(pipeline, "_fused", lambda *a: (500.0, 10.0))
    monkeypatch.setattr(pipeline, "outside_blocks", lambda summary, n: {"channel": 0.0})
    args = argparse.Namespace(transport=["zmq"], method="fft_peak")
    for preset, pairs, ratio in (("table1", [("table1", False), ("table1_following", False),
                                             ("table1_following", True)], 800 / 900),
                                 ("awr1642", [("awr1642", False), ("awr1642", True)], 40 / 50)):
        calls.clear()
        runs = pipeline._Runs({("pipeline", "zmq"): [], ("tracker", "zmq"): [], ("fused", "none"): []})
        pipeline._repeat(runs, (preset, "beat", 100), args, 8)
        assert calls == pairs
        base = {"preset": preset, "fidelity": "beat", "batch": 8, "cycles": 100, "repeats": 1,
                "method": "fft_peak", "radar_cycles_per_s": 2131.0}
        rec, _ = pipeline._record(runs, "tracker", "zmq", base, 1)
        assert rec["tracker_scene"] == pairs[-1][0]                 # the scene the tracker ran on
        assert rec["runs_ratio_to_pipeline"] == [ratio] and rec["runs_tracks"] == [{"born": 1, "deleted": 0}]


def test_the_trackers_scene_on_table1_is_the_tracks_graphs_and_its_car_keeps_its_range():
    """The scene the tracker's paired runs take on table1 is the one graphs/table1_tracks.toml tracks on: Table I's
    radar, and a car with no range rate (the frozen geometry holds it where a constant-velocity track puts it)."""
    scene = pipeline.TRACKER_SCENES["table1"]
    assert scene == load_graph(graph_file("table1_tracks")).params["scene"]
    following, table1 = scene_of(scene), scene_of("table1")
    assert following.frame_shape(1) == table1.frame_shape(1) and following.t_cycle_s == table1.t_cycle_s
    assert [following.range_rate_mps(t) for t in following.targets] == [0.0]
    assert [round(table1.range_rate_mps(t), 3) for t in table1.targets] == [-1.111]


def test_the_extra_modes_are_any_of_record_replay_and_tracker_and_replay_needs_record():
    assert _modes("tracker") == ["tracker"] and _modes("record,replay,tracker") == ["record", "replay", "tracker"]
    assert _modes("none") == []
    for bad in ("replay", "tracker,replay", "fused"):
        with pytest.raises(argparse.ArgumentTypeError, match="replay needs record"):
            _modes(bad)


@pytest.mark.parametrize("busy, outside, cores, expected", [
    # one block of 500 us a cycle: 2000 cycles/s, though the three share 2 cores at 2 / 750 us; its time outside
    # the block (the I/O thread's, say) may overlap it, so it counts toward the cores only
    ({"a": 500.0, "b": 100.0, "c": 100.0}, {"a": 50.0}, 2, (2000.0, "a")),
    # balanced nodes: the cores bind, 2 cores over 900 us of CPU a cycle
    ({"a": 300.0, "b": 300.0, "c": 200.0}, {"a": 0.0, "b": 0.0, "c": 100.0}, 2, (2e6 / 900, "2 cores")),
    # one core: the sum binds whatever the split
    ({"a": 300.0, "b": 300.0}, {}, 1, (1e6 / 600, "1 core"))])
def test_the_ceiling_is_the_busiest_node_or_the_cores_whichever_allows_fewer_cycles(busy, outside, cores, expected):
    rate, what = ceiling(busy, outside, cores)
    assert what == expected[1] and rate == pytest.approx(expected[0], rel=1e-12)


@pytest.mark.integration
def test_bench_pipeline_writes_a_record_per_case_mode_and_batch(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert run_bench(["pipeline", "--cases", "awr1642:beat", "--repeats", "1", "--scale", "0.04",
                  "--batch", "4,8", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["command"] == "python3 dev.py bench pipeline --cases awr1642:beat --repeats 1 --scale 0.04 --batch 4,8"
    assert doc["machine"]["cores"] >= 1
    records = doc["records"]
    assert [(r["preset"], r["fidelity"], r["mode"], r["transport"], r["batch"]) for r in records] == [
        ("awr1642", "beat", mode, transport, b) for b in (4, 8)
        for mode, transport in (("pipeline", "zmq"), ("pipeline", "shm"), ("tracker", "zmq"), ("fused", "none"),
                                ("record", "zmq"), ("replay", "zmq"))]
    for r in records:
        assert r["cycles"] == 40 and r["cycles_per_s"] > 0 and r["real_time_factor"] == r["cycles_per_s"] / 25.0
    assert all(set(r["busy_us_per_cycle"]) >= {"channel", "ranging"} for r in records if r["mode"] == "pipeline")
    # what each node spends outside its block: one figure per node, and a node moving frames spends some
    assert all(set(r["outside_us_per_cycle"]) == set(r["busy_us_per_cycle"]) and r["outside_us_per_cycle"]["gate"] > 0
               for r in records if r["mode"] == "pipeline")
    assert all(r["cpu_us_per_cycle"] > 0 for r in records if r["mode"] == "fused")   # measured in its own process
    # the graph's CPU per cycle: every node's, in and outside its block (one repeat: that run's sum)
    for r in records:
        if r["mode"] == "pipeline":
            total = sum(r["busy_us_per_cycle"].values()) + sum(r["outside_us_per_cycle"].values())
            assert r["cpu_us_per_cycle"] == pytest.approx(total, rel=1e-12)
    # against the fused chain of the same repeat, repeat by repeat, and the median of those ratios
    fused = {r["batch"]: r["runs_cycles_per_s"] for r in records if r["mode"] == "fused"}
    for r in records:
        assert r["runs_speedup_over_fused"] == [x / f for x, f in zip(r["runs_cycles_per_s"], fused[r["batch"]])]
        assert r["speedup_over_fused"] == statistics.median(r["runs_speedup_over_fused"])
    # the tracker against the pipeline on the same plane, repeat by repeat; what it loses of the graph's cycles/s
    pipeline = next(r for r in records if r["mode"] == "pipeline" and r["transport"] == "zmq" and r["batch"] == 4)
    tracked = next(r for r in records if r["mode"] == "tracker" and r["batch"] == 4)
    assert tracked["runs_ratio_to_pipeline"] == [t / p for t, p in zip(tracked["runs_cycles_per_s"],
                                                                       pipeline["runs_cycles_per_s"])]
    assert tracked["cycles_per_s_loss"] == 1 - statistics.median(tracked["runs_ratio_to_pipeline"])
    assert tracked["loss_target"] == 0.05 and tracked["busy_us_per_cycle"]["tracker"] > 0
    assert tracked["tracker_scene"] == "awr1642" and tracked["runs_paired_pipeline_cycles_per_s"] == \
        pipeline["runs_cycles_per_s"] and all(t["born"] >= 1 for t in tracked["runs_tracks"])
    assert "tracker" not in pipeline["busy_us_per_cycle"]
    # on disk: awr1642's 128 chirps x 256 real int16 codes per cycle, nothing else
    assert all(r["bytes_per_cycle"] == 128 * 256 * 2 for r in records if r["mode"] in ("record", "replay"))
    assert all("recorder" in r["busy_us_per_cycle"] for r in records if r["mode"] == "record")
    # each node's busy time per sample: us per cycle over awr1642's 128 x 256 samples, for every graph mode
    graphs = [r for r in records if r["mode"] != "fused"]
    assert graphs and all(r["samples_per_cycle"] == 128 * 256 for r in graphs)
    for r in graphs:
        assert set(r["busy_ns_per_sample"]) == set(r["busy_us_per_cycle"])
        for node, ns in r["busy_ns_per_sample"].items():
            assert math.isfinite(ns) and ns > 0, (node, ns)
            assert ns == pytest.approx(r["busy_us_per_cycle"][node] * 1e3 / (128 * 256), rel=1e-12)
    printed = capsys.readouterr().out
    assert printed.startswith("machine: ") and f"({doc['machine']['simd']})" in printed.splitlines()[0]
    channel = graphs[0]["busy_ns_per_sample"]["channel"]
    assert "busy us/cycle (ns/sample, 128 x 256 a cycle): " in printed and f"({channel:.2f})" in printed


@pytest.mark.integration
def test_bench_pipeline_runs_the_mimo_scene_with_its_recording_and_replay_of_every_receiver(tmp_path, capsys):
    out = tmp_path / "bench.json"
    assert run_bench(["pipeline", "--cases", "awr1642_mimo:waveform", "--repeats", "1", "--scale", "0.02",
                      "--batch", "4", "--transport", "shm", "--json", str(out)]) == 0
    records = json.loads(out.read_text())["records"]
    assert [(r["preset"], r["fidelity"], r["mode"], r["transport"]) for r in records] == [
        ("awr1642_mimo", "waveform", mode, transport) for mode, transport in (
            ("pipeline", "shm"), ("tracker", "shm"), ("fused", "none"), ("record", "shm"), ("replay", "shm"))]
    assert records[0]["samples_per_cycle"] == 4 * 128 * 256 and records[0]["real_time_factor"] > 0
    # on disk: 4 receivers x 128 chirps x 256 real int16 codes per cycle
    assert all(r["bytes_per_cycle"] == 4 * 128 * 256 * 2 and r["cycles_per_s"] > 0
               for r in records if r["mode"] in ("record", "replay"))
    assert "recorder" in records[3]["busy_us_per_cycle"] and "source" in records[4]["busy_us_per_cycle"]
    printed = capsys.readouterr().out
    assert "left out" not in printed
    assert "busy us/cycle (ns/sample, 4 x 128 x 256 a cycle): " in printed
