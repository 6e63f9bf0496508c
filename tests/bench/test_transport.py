"""`python3 dev.py bench transport`: the runtime chain (bench/chain.toml) and the bare pyzmq chain move the same
frames."""
import pytest

from bench.transport import CHAIN_GRAPH, HOPS, chain_overrides, run_raw, run_runtime
from carav_stream.runtime.loader import load_graph


def test_the_chain_graph_is_six_processes_in_a_line_with_the_case_set_by_overrides():
    g = load_graph(CHAIN_GRAPH, chain_overrides((4, 32), queue_frames=2, warmup=3, rate_hz=50))
    assert len(g.nodes) == HOPS + 1 and len(g.edges) == HOPS and g.sources() == ["src"]
    assert g.nodes["src"].params == {"n_chirps": 4, "n_samples": 32, "rate_hz": 50.0}
    assert g.nodes["sink"].params["warmup_frames"] == 3 and g.run["queue_frames"] == 2


@pytest.mark.integration
def test_both_chains_deliver_every_frame_in_order_with_the_same_payload_size():
    kw = {"queue_frames": 2, "warmup": 2}
    runtime, raw = run_runtime((4, 32), 30, **kw), run_raw((4, 32), 30, timeout_s=60, **kw)
    assert runtime["frames"] == 30 and runtime["in_order"]
    assert runtime["bytes_per_frame"] == raw["bytes_per_frame"] == 4 * 32 * 8
    for figs in (runtime, raw):
        assert figs["frames_per_s"] > 0 and 0 < figs["latency_median_s"] <= figs["latency_p99_s"]
        assert len(figs["cpu_ms_per_frame_by_node"]) == HOPS + 1
