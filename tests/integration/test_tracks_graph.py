"""graphs/table1_tracks.toml as real processes: the tracker behind the radar chain, a range-gate pull-off on the car.

With CARAV (the graph as written) the gate refuses every attacked cycle: the car's track coasts through the whole
attack at the car and is updated again after it, one track from start to end. With the detector unable to alarm
(`--set detector.eta=1e9`) the same run drags the picture onto the false echo, and the car is found again only once
the repeater stops. Either way the tracker reports every cycle once, in order, and the run summary's track figures
(printed and in --json) are those its log of every cycle gives."""
import json

import numpy as np
import pytest
from scipy.io import loadmat

from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.streams import scene_of
from carav_stream.runtime.loader import load_graph
from carav_stream.testing.graphs import by_cycle
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
    summary = json.loads(out.read_text())
    _check_track_figures(summary["tracks"], cycles, done.stdout)
    return cycles, summary


def _figures_from_log(cycles: dict[int, dict], gate: tuple[float, float]) -> dict:
    """The summary's track figures counted again from tracks.jsonl, cycle by cycle, against the scene's one car."""
    scene = scene_of("table1_following")
    car = (scene.targets[0].range_m, scene.range_rate_mps(scene.targets[0]))
    confirmed, false, was_on, on_last = set(), set(), set(), {}
    held = coasted = lost = deleted = 0
    first_held = start = carav = nis = None
    for c in sorted(cycles):
        row = cycles[c]
        deleted += sum(on_last.pop(i, False) for i in row["deleted"])
        on_car = []
        for i, status, r, v in zip(row["track_id"], row["status"], row["range_m"], row["velocity_mps"]):
            if status != "tentative":
                on = abs(r - car[0]) <= gate[0] and abs(v - car[1]) <= gate[1]
                confirmed.add(i)
                (was_on if on else false).add(i)
                on_last[i] = on
                on_car += [status] if on else []
        first_held = c if first_held is None and on_car else first_held
        if first_held is not None:
            held += "confirmed" in on_car
            coasted += bool(on_car) and "confirmed" not in on_car
            lost += not on_car
        start = c if start is None and row["attack_active"] else start
        if start is not None:
            carav = c if carav is None and row["reason"] == "attack" else carav
            nis = c if nis is None and any(row["nis_alarm"]) else nis
    return {"confirmed": len(confirmed), "false": sorted(false), "dragged": len(false & was_on),
            "car": (first_held, held, coasted, lost, deleted), "start": start, "carav": carav, "nis": nis}


def _check_track_figures(t: dict, cycles: dict[int, dict], printed: str) -> None:
    """The JSON summary's "tracks" as the tracker's own log gives them, and the printed summary saying the same."""
    log = _figures_from_log(cycles, (t["truth_gate"]["range_m"], t["truth_gate"]["velocity_mps"]))
    (car,) = t["targets"]
    assert (t["confirmed_tracks"], t["false_track_ids"], t["dragged_tracks"]) == \
        (log["confirmed"], log["false"], log["dragged"])
    assert t["false_tracks"] == len(log["false"])
    assert (car["first_held_cycle"], car["held_cycles"], car["coasted_cycles"], car["lost_cycles"],
            car["deleted_tracks"]) == log["car"]
    assert t["attack_start_cycle"] == log["start"]
    dt_ms = scene_of("table1_following").t_cycle_s * 1e3
    for key in ("carav", "nis"):
        first = t["first_alarm"][key]
        assert (first and first["cycle"]) == log[key]
        if first:
            assert first["cycles"] == log[key] - log["start"] and first["ms"] == pytest.approx(first["cycles"] * dt_ms)
    assert (f"; {t['confirmed_tracks']} confirmed, {t['false_tracks']} false") in printed
    assert (f"held from cycle {car['first_held_cycle']}: updated {car['held_cycles']} cycles, coasted "
            f"{car['coasted_cycles']}, lost {car['lost_cycles']}; its tracks deleted {car['deleted_tracks']}"
            in printed)
    words = {k: "none" if v is None else f"after {v['cycles']} cycles ({v['ms']:.3g} ms)"
             for k, v in t["first_alarm"].items()}
    assert (f"first alarm from the attack's start (cycle {log['start']}): CARAV {words['carav']}, NIS alarm "
            f"{words['nis']}") in printed


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
    # in the run summary: one track, on the car throughout; it coasts through the attack, refused from its first cycle
    tracks = summary["tracks"]
    assert (tracks["confirmed_tracks"], tracks["false_tracks"]) == (1, 0)
    (car,) = tracks["targets"]
    assert car["coasted_cycles"] == last - first and car["lost_cycles"] == 0 and car["deleted_tracks"] == 0
    assert tracks["attack_start_cycle"] == first and tracks["first_alarm"]["carav"]["cycles"] == 0


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
    # in the run summary: confirmed tracks on the false echo, off the car; the car's track lost for long; no CARAV
    # alarm, and the NIS alarm after the capture, once the drag has begun
    tracks = summary["tracks"]
    assert tracks["false_tracks"] > 0 and tracks["first_alarm"]["carav"] is None
    on_echo = {i for c in far for i, s in zip(cycles[c]["track_id"], cycles[c]["status"]) if s != "tentative"}
    assert on_echo and on_echo <= set(tracks["false_track_ids"])
    assert tracks["targets"][0]["lost_cycles"] > len(far) // 2 and tracks["targets"][0]["deleted_tracks"] >= 1
    assert tracks["first_alarm"]["nis"]["cycles"] > attack["capture_cycles"]


TRACK_KEYS = {"track_id": "track_id", "status": "track_status", "range_m": "track_range_m",
              "velocity_mps": "track_velocity_mps", "var_range_m2": "track_var_range_m2",
              "var_velocity_m2ps2": "track_var_velocity_m2ps2", "nis_alarm": "track_nis_alarm"}


def test_a_recording_keeps_every_cycles_tracks_and_replay_and_export_carry_them(carav):
    """carav record puts the tracks of every cycle into its annotations; carav replay tracks the recording again
    with the recorded tracker (the same tracks, bit for bit, and the same figures); carav export gives them as
    per-cycle columns."""
    live_dir, n = carav.workdir / "live", 300            # the attack from cycle 200: coasting in the last 100
    done = carav.cli("record", str(GRAPH), "--out", str(live_dir), "--cycles", str(n), "--no-progress", "--json",
                     str(carav.workdir / "live.json"))
    assert done.returncode == 0, done.stderr
    logged = by_cycle(read_jsonl(carav.workdir / "tracks.jsonl"))
    ann = json.loads((live_dir / "recording.sigmf-meta").read_text())["annotations"]
    assert [a["carav:cycle"] for a in ann] == sorted(logged) == list(range(n))
    assert all(a[f"carav:{name}"] == logged[a["carav:cycle"]][key] for a in ann for key, name in TRACK_KEYS.items())
    assert {s for a in ann for s in a["carav:track_status"]} == {"tentative", "confirmed", "coasting"}
    done = carav.cli("replay", str(live_dir), "--tracks", str(carav.workdir / "again.jsonl"), "--no-progress",
                     "--json", str(carav.workdir / "replay.json"))
    assert done.returncode == 0, done.stderr
    again = by_cycle(read_jsonl(carav.workdir / "again.jsonl"))
    assert sorted(again) == list(range(n))
    per_cycle = set(read_jsonl(carav.workdir / "tracks.jsonl")[0]["per_cycle"])     # the frames' own headers apart
    assert per_cycle >= set(TRACK_KEYS) | {"measured", "reason", "born", "deleted", "nis"}
    assert all({k: again[c][k] for k in per_cycle} == {k: logged[c][k] for k in per_cycle} for c in range(n))
    live, replay = (json.loads((carav.workdir / f).read_text()) for f in ("live.json", "replay.json"))
    assert replay["tracks"] == live["tracks"] and live["tracks"]["targets"][0]["coasted_cycles"] == 100
    done = carav.cli("export", str(live_dir), "--mat", str(carav.workdir / "rec.mat"), "--quiet",
                     "--no-activation")
    assert done.returncode == 0, done.stderr
    per = loadmat(str(carav.workdir / "rec.mat"), simplify_cells=True)["per_cycle"]
    for key in ("range_m", "velocity_mps"):                 # one live track a cycle here: a column
        np.testing.assert_array_equal(np.ravel(per[f"track_{key}"]), [logged[c][key][0] for c in range(n)])
    assert [str(s) for s in per["track_status"]] == [logged[c]["status"][0] for c in range(n)]
