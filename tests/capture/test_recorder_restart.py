"""A recorder is never restarted: a graph that gives sigmf_sink a restart policy is refused at validation, in one
line naming the node, and `carav record` gives its recorder restart "never" whatever the recorded graph's policy."""
from pathlib import Path

import pytest

from carav_stream.cli.record import NODE, record_graph
from carav_stream.runtime.graph import GraphError
from carav_stream.runtime.loader import load_graph

CHAIN = Path(__file__).resolve().parents[2] / "graphs" / "radar_chain.toml"


def test_a_recorder_with_a_restart_policy_is_refused_in_one_line_naming_it(tmp_path):
    graph = tmp_path / "g.toml"
    graph.write_text(f'include = "{CHAIN}"\n[restart]\npolicy = "on-failure"\n')
    recorded = record_graph(load_graph(graph), tmp_path)
    assert load_graph(recorded).nodes[NODE].restart.policy == "never"      # carav record's own recorder
    restarted = tmp_path / "restarted.toml"
    restarted.write_text(recorded.read_text().replace('restart = "never"', 'restart = "on-failure"'))
    with pytest.raises(GraphError) as info:
        load_graph(restarted)
    [problem] = [p for p in info.value.problems if "restart" in p]
    assert f"blocks.{NODE}.restart: a sigmf_sink cannot be restarted" in problem and "\n" not in problem
    assert 'give it restart = "never"' in problem


def test_carav_record_wires_the_trackers_tracks_to_its_recorder_and_refuses_two_trackers(tmp_path):
    from carav_stream.console.errors import CommandError
    tracks = CHAIN.parent / "table1_tracks.toml"
    g = load_graph(record_graph(load_graph(tracks), tmp_path))
    assert "tracker.tracks -> recorder.tracks" in {str(e) for e in g.edges}
    assert not [e for e in load_graph(record_graph(load_graph(CHAIN), tmp_path)).edges if e.dst_port == "tracks"]
    two = tmp_path / "two.toml"
    two.write_text(f'include = "{tracks}"\nconnections = ["ranging.estimates -> again.estimates"]\n[blocks]\n'
                   'again = { type = "tracker", sigma_range_m = 0.01, sigma_velocity_mps = 0.1 }\n')
    with pytest.raises(CommandError, match="one tracker; the graph has 2: tracker, again"):
        record_graph(load_graph(two), tmp_path)
