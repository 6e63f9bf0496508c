"""`carav replay` runs the recording through the settings it was judged and ranged with: every recorded setting
of the detector and the estimator that changes what they report is carried onto the replay graph's nodes."""
import json
from pathlib import Path

from carav_stream.cli.replay import overrides_for


class Recorded:
    """What overrides_for reads of a recording: its scene, base name and global fields."""

    def __init__(self, nodes: dict) -> None:
        self.scene_ref, self.base = "awr1642", Path("/rec/run")
        self.fields = {"batch": 4, "graph": {"nodes": nodes}}

    def global_field(self, key: str):
        return self.fields.get(key)


def test_the_recorded_estimators_unfolding_reach_is_replayed_with_it():
    # awr1642's car closes beyond the unambiguous velocity: without max_speed_mps the replay would report the alias
    live = {"ranging": {"type": "range_estimator", "method": "ml", "max_speed_mps": 100.0},
            "detector": {"type": "rms_detector", "eta": 1.13}}
    blocks = {"player": {"type": "sigmf_source"}, "rng": {"type": "range_estimator"},
              "det": {"type": "rms_detector"}}
    out = overrides_for(Recorded(live), "player", blocks, recorded_settings=True)
    assert "rng.max_speed_mps=100.0" in out and 'rng.method="ml"' in out and "det.eta=1.13" in out
    assert f"player.path={json.dumps('/rec/run')}" in out and "batch=4" in out


def test_without_recorded_settings_only_the_recording_itself_is_pointed_at():
    live = {"ranging": {"type": "range_estimator", "max_speed_mps": 100.0}}
    out = overrides_for(Recorded(live), "player", {"rng": {"type": "range_estimator"}}, recorded_settings=False)
    assert not [o for o in out if o.startswith("rng.")]


def test_the_recorded_tracker_is_replayed_with_its_settings_on_the_gate_and_the_estimator(tmp_path):
    import shutil

    from carav_graphs import graph_file
    from carav_stream.cli.replay import player_nodes, recorded_tracker, with_tracker
    from carav_stream.runtime.loader import load_graph
    tracked = load_graph(graph_file("table1_tracks"))
    live = {n: {"type": node.type, **node.params} for n, node in tracked.nodes.items()}
    rec = Recorded(live)
    rec.scene_ref = "table1_following"
    tracker = recorded_tracker(rec)
    assert tracker == live["tracker"]
    replay = graph_file("replay")
    (player,), blocks = player_nodes(replay)
    path = with_tracker(replay, blocks, tracker, tmp_path / "t.jsonl")
    try:
        # the recording left open (a template's parameter): what is checked is the composition
        sets = [o for o in overrides_for(rec, player, blocks, recorded_settings=True) if not o.startswith(player)]
        g = load_graph(path, sets, open_ok=True)
    finally:
        shutil.rmtree(path.parent)
    assert g.nodes["tracker"].params == tracked.nodes["tracker"].params        # the scene from the recording
    assert {str(e) for e in g.edges if "tracker" in str(e)} == {
        "ranging.estimates -> tracker.estimates", "gate.alarms -> tracker.alarms", "tracker.tracks -> tracks_log.inp"}
    assert g.nodes["tracks_log"].params["path"] == str(tmp_path / "t.jsonl")
    assert recorded_tracker(Recorded({"ranging": {"type": "range_estimator"}})) is None
