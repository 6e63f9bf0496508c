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
