"""The live view's tables, without a browser: node rates over the last status interval, edges beyond their capacity
with the supervisor's reason, and the supervisor's side of it (counters read apart, the reason given); what
`carav run --view` taps."""
from types import SimpleNamespace

import pytest

from carav_stream.runtime.admin_server import AdminServer
from carav_stream.runtime.graph import Edge
from carav_stream.runtime.node_state import NodeState
from carav_stream.view.page import edge_rows, node_rows


def status(elapsed, cycles, processed, restarts=0):
    return {"elapsed_s": elapsed, "nodes": {"source": {
        "block": "chirp_source", "alive": True, "restarts": restarts, "cycles_total": cycles, "processed": processed,
        "cycles_per_s": cycles / elapsed, "rate_per_s": processed / elapsed}}}


def test_the_node_table_gives_cycles_so_far_and_rates_over_the_last_interval_not_the_runs_average():
    first = node_rows(status(10.0, 10_000, 320), None)
    assert first["cycles"] == [10_000] and first["cycles_s"] == [1000.0] and first["frames_s"] == [32.0]
    later = node_rows(status(12.0, 10_400, 333), status(10.0, 10_000, 320))
    assert later["cycles"] == [10_400] and later["cycles_s"] == [200.0] and later["frames_s"] == [6.5]
    assert later["state"] == ["up"]


def test_an_edge_beyond_its_capacity_says_why():
    rows = edge_rows({"edges": {"a.out -> b.inp": {"in_flight": 3, "capacity": 16, "skipped": 0},
                                "b.out -> c.inp": {"in_flight": 42, "capacity": 16, "skipped": 5,
                                                   "beyond_capacity": "the reason"}}})
    assert rows["fill"] == ["3 / 16", "42 / 16 (the reason)"] and rows["skipped"] == [0, 5]


def test_the_supervisor_names_counters_read_apart_when_in_flight_exceeds_the_queues():
    def node(name, last_seen, **counters):
        return NodeState(name, spec=None, last_seen=last_seen, counters=counters)
    edge = Edge("a", "out", "b", "inp")
    graph = SimpleNamespace(run={"queue_frames": 8}, edges=[edge])
    server = SimpleNamespace(graph=graph, nodes={"a": node("a", 5.0, sent={str(edge): 100}),
                                                 "b": node("b", 4.2, **{"in": {"inp": 58}})})
    q = AdminServer.edge_queues(server)[str(edge)]
    assert q["in_flight"] == 42 and q["capacity"] == 16 and q["counters_apart_s"] == 0.8
    assert "the producer's count is 0.8 s newer than the consumer's" in q["beyond_capacity"]
    server.nodes["a"] = node("a", 5.0, sent={str(edge): 60})
    assert "beyond_capacity" not in AdminServer.edge_queues(server)[str(edge)]


def test_carav_run_view_taps_a_trackers_tracks_and_asks_the_page_for_them():
    import shutil

    from carav_graphs import graph_file
    from carav_stream.cli.view import view_graph
    from carav_stream.runtime.loader import load_graph
    pytest.importorskip("bokeh")
    for name, tracked in (("table1_tracks", True), ("demo", False)):
        path = view_graph(load_graph(graph_file(name)), "127.0.0.1", 5006, "token")
        try:
            g = load_graph(path)
        finally:
            shutil.rmtree(path.parent)
        taps = {str(e) for e in g.edges if e.dst == "view"}
        assert ("tracker.tracks -> view.tracks" in taps) == tracked
        assert g.nodes["view"].params.get("tracks", False) == tracked
        assert {"gate.alarms -> view.alarms", "gate.clean -> view.clean", "ranging.estimates -> view.estimates"} <= taps
