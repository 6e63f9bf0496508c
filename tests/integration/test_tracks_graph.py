"""graphs/table1_tracks.toml as real processes: the tracker behind the radar chain, a range-gate pull-off on the car.

With CARAV (the graph as written) the gate refuses every attacked cycle: the car's track coasts through the whole
attack at the car and is updated again after it, one track from start to end. With the detector unable to alarm
(`--set detector.eta=1e9`) the same run drags the picture onto the false echo, and the car is found again only once
the repeater stops. Either way the tracker reports every cycle once, in order."""
import json

import numpy as np
import pytest

from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.loader import load_graph
from tests.integration.conftest import ROOT, read_jsonl

pytestmark = pytest.mark.integration

GRAPH = ROOT / "graphs" / "table1_tracks.toml"


def _run(carav, *sets: str) -> tuple[dict[int, dict], dict]:
    out = carav.workdir / "s.json"
    done = carav.cli("run", str(GRAPH), "--no-progress", "--json", str(out), *sum((["--set", s] for s in sets), []))
    assert done.returncode == 0, done.stderr
    cycles: dict[int, dict] = {}
    for line in read_jsonl(carav.workdir / "tracks.jsonl"):
        per = line["per_cycle"]
        for i, c in enumerate(per["cycle_index"]):
            assert c not in cycles, f"cycle {c} reported twice"
            cycles[c] = {k: v[i] for k, v in per.items()}
    return cycles, json.loads(out.read_text())


def _tracker_summary(summary: dict) -> dict:
    return summary["per_node"]["tracker"]["history"][-1]["summary"]


@pytest.fixture(scope="module")
def graph():
    g = load_graph(GRAPH)
    attack = g.nodes["attacker"].params
    return g, attack


def test_with_carav_the_cars_track_coasts_through_the_pull_off_and_stays_on_the_car(carav, graph):
    g, attack = graph
    cycles, summary = _run(carav)
    n, first, last = g.run["cycles"], attack["start_cycle"], attack["start_cycle"] + attack["n_active_cycles"]
    assert sorted(cycles) == list(range(n)) and summary["lost"] == 0
    assert [c for c in range(n) if not cycles[c]["measured"]] == list(range(first, last))
    assert all(cycles[c]["reason"] == "attack" and cycles[c]["attack_active"] for c in range(first, last))
    assert all(cycles[c]["track_id"] == [0] for c in range(5, n))            # one track, never deleted
    assert all(cycles[c]["status"] == ["coasting"] for c in range(first, last))
    assert all(cycles[c]["status"] == ["confirmed"] for c in range(last, n))
    ranges = np.array([cycles[c]["range_m"][0] for c in range(5, n)])
    assert np.all(np.abs(ranges - scene_of("table1_following").targets[0].range_m) < 0.05)
    var = [cycles[c]["var_range_m2"][0] for c in range(first, last)]
    assert all(b > a for a, b in zip(var, var[1:]))
    t = _tracker_summary(summary)
    assert t["cycles"] == n and t["late"] == 0 and t["unsent_cycles"] == 0 and t["deleted"] == 0
    assert t["unmeasured_by_reason"] == {"attack": last - first}


def test_without_the_detector_the_picture_follows_the_false_echo(carav, graph):
    g, attack = graph
    cycles, summary = _run(carav, "detector.eta=1e9")
    n, last = g.run["cycles"], attack["start_cycle"] + attack["n_active_cycles"]
    assert sorted(cycles) == list(range(n)) and all(cycles[c]["measured"] for c in range(n))
    scene = scene_of("table1_following")
    car = scene.targets[0].range_m
    model = make_attacker("pull_off", scene, **{k: v for k, v in attack.items() if k not in ("model", "scene", "seed")})
    far = [c for c in range(n) if c < last and model.offset(c)[0] > 1.2]      # a range cell and more from the car
    assert len(far) > 100
    for c in far:
        false_m = car + model.offset(c)[0]
        assert cycles[c]["range_m"] and all(abs(r - false_m) < 0.1 for r in cycles[c]["range_m"]), c
    assert 0 in [i for c in range(n) for i in cycles[c]["deleted"]]                  # the car's first track is gone
    end = cycles[n - 1]
    assert end["status"] == ["confirmed"] and abs(end["range_m"][0] - car) < 0.05     # found again after the attack
    assert _tracker_summary(summary)["born"] > 2
