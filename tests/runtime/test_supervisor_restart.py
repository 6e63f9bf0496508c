"""A node restarted by policy: everything downstream of it is told to recover, not only its consumers.

Frames that died with the node never come; a node two hops down that pairs a stream through it with another (the
radar's detector pairs adc's frames, through the channel, with the source's rho) would otherwise keep a full
buffer of the other stream waiting for them, the source would block on it, and the graph would stall."""
from pathlib import Path

from carav_stream.runtime.loader import load_graph
from carav_stream.runtime.protocol import Control
from carav_stream.runtime.supervisor import Supervisor

GRAPH = Path(__file__).resolve().parents[1] / "integration" / "graphs" / "radar_taps_restart.toml"


def test_a_restart_tells_every_node_downstream_to_recover_and_no_other(monkeypatch):
    graph = load_graph(GRAPH)             # the radar chain with taps, every node restarted after a crash
    sup = Supervisor(graph, log=lambda text: None)
    sup.plan()
    sent = []
    monkeypatch.setattr(sup, "send", lambda node, kind, **fields: sent.append((node, kind)))
    monkeypatch.setattr(sup, "spawn", lambda st: None)
    sup.node_failed(sup.nodes["channel"], "killed")
    recovering = {node for node, kind in sent if kind == Control.RECOVER}
    # channel -> attacker, adc, alog (its air tap); adc -> detector, gate; detector -> gate, vlog; gate -> ranging,
    # summary, elog, csv; ranging -> summary, elog, csv. Not the source, nor rlog (the source's rho tap).
    assert recovering == {"attacker", "adc", "alog", "detector", "gate", "vlog", "ranging", "summary", "elog", "csv"}
    assert ("source", Control.RECONNECT) in sent            # its producer connects afresh to the new incarnation
