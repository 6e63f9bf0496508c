"""Tracker block: the estimator's and the gate's records put back in cycle order, every cycle tracked once, a
refused cycle coasted through, outputs with growing seqs, and the figures of a run in its summary."""
import numpy as np
import pytest

from carav_blocks.tracker import Tracker
from carav_stream.radar.streams import scene_of
from carav_stream.runtime import Frame
from carav_stream.testing.harness import wire

SCENE = "table1_following"
R0 = 43.0
PARAMS = {"scene": SCENE, "sigma_range_m": 0.0025, "sigma_velocity_mps": 0.01, "coast_cycles": 20}
BATCH = 8


def _source_frames(n_cycles: int, refused: set[int], seed: int = 0):
    """Per source frame (seq) of BATCH cycles: the estimator's frame of its clean cycles (None when every cycle was
    refused) and the gate's alarm frame of the refused ones (None when none was), as the chain makes them."""
    rng = np.random.default_rng(seed)
    out = []
    for seq, c0 in enumerate(range(0, n_cycles, BATCH)):
        cycles = list(range(c0, min(c0 + BATCH, n_cycles)))
        clean = [c for c in cycles if c not in refused]
        bad = [c for c in cycles if c in refused]
        est = None if not clean else wire(Frame.of(None, cycle=c0, cycles=len(clean), method="ml", per_cycle={
            "cycle_index": clean, "attack_active": [False] * len(clean),
            "range_m": [[R0 + 0.0025 * rng.normal()] for _ in clean],
            "velocity_mps": [[0.01 * rng.normal()] for _ in clean]}), seq, "ranging.estimates")
        alarms = None if not bad else wire(Frame.of(None, cycle=c0, cycles=len(bad), alarm=True, per_cycle={
            "cycle_index": bad, "attack_active": [True] * len(bad), "reason": ["attack"] * len(bad)}), seq,
            "gate.alarms")
        out.append((est, alarms))
    return out


def _feed(block: Tracker, order: list[tuple[str, Frame]]) -> list[tuple[int, Frame]]:
    """Hand the frames to the block in this arrival order; (seq the runtime stamps, frame) of every output."""
    sent, last = [], None
    for port, frame in order:
        out = block.process(*((frame, None) if port == "estimates" else (None, frame)))
        last = frame.seq
        if out is not None:
            sent.append((frame.seq, wire(out, frame.seq, "tracker.tracks")))
    end = block.finish()
    if end is not None:
        sent.append((last + 1, wire(end, last + 1, "tracker.tracks")))
    return sent


def _column(sent, name):
    return [v for _, f in sent for v in f.header["per_cycle"][name]]


def _arrivals(frames, alarms_ahead: int):
    """Arrival order: each alarm frame comes `alarms_ahead` source frames before the estimates of its seq (a
    negative value: after)."""
    timeline = []
    for seq, (est, alarms) in enumerate(frames):
        if est is not None:
            timeline.append((seq, 1, "estimates", est))
        if alarms is not None:
            timeline.append((seq - alarms_ahead, 0, "alarms", alarms))
    return [(port, f) for _, _, port, f in sorted(timeline, key=lambda t: (t[0], t[1]))]


@pytest.mark.parametrize("alarms_ahead", [0, 2, -2])
def test_every_cycle_is_tracked_once_in_cycle_order_whatever_the_arrival_order(alarms_ahead):
    refused = set(range(30, 45)) | {3, 60, 61}
    block = Tracker(**PARAMS)
    block.start()
    sent = _feed(block, _arrivals(_source_frames(96, refused), alarms_ahead))
    seqs = [s for s, _ in sent]
    assert seqs == sorted(set(seqs)), "output seqs must grow"
    assert _column(sent, "cycle_index") == list(range(96))
    measured = _column(sent, "measured")
    assert [c for c in range(96) if not measured[c]] == sorted(refused)
    assert all(r == "attack" for c, r in enumerate(_column(sent, "reason")) if c in refused)
    summary = block.summary()
    assert summary["cycles"] == 96 and summary["measured"] == 96 - len(refused) and summary["late"] == 0
    assert summary["unmeasured_by_reason"] == {"attack": len(refused)} and summary["unsent_cycles"] == 0


def test_the_track_coasts_through_refused_cycles_and_is_kept_within_the_coast_limit():
    refused = set(range(30, 50))                               # 20 cycles = coast_cycles
    block = Tracker(**PARAMS)
    block.start()
    sent = _feed(block, _arrivals(_source_frames(80, refused), 1))
    ids, status = _column(sent, "track_id"), _column(sent, "status")
    assert all(ids[c] == [0] for c in range(80))
    assert all(status[c] == ["coasting"] for c in refused) and status[79] == ["confirmed"]
    var = [v[0] for v in _column(sent, "var_range_m2")]
    assert all(var[c + 1] > var[c] for c in range(30, 49))     # the covariance grows while it coasts
    assert all(n == [None] for n in (_column(sent, "nis")[c] for c in refused))
    assert _column(sent, "nis_alarm")[0] is None               # the NIS alarm is off unless asked for


def test_the_runs_track_figures_go_to_the_run_summary_with_the_counts():
    refused = set(range(30, 50))
    block = Tracker(**{**PARAMS, "nis_pfa": 1e-3, "nis_window": 4})
    block.start()
    _feed(block, _arrivals(_source_frames(80, refused), 1))
    summary = block.summary()
    t = summary["run"]["tracks"]
    assert {k: t[k] for k in ("cycles", "measured", "unmeasured_by_reason")} == \
        {"cycles": 80, "measured": 60, "unmeasured_by_reason": {"attack": 20}}
    assert all(t[k] == v for k, v in summary.items() if k != "run")
    assert (t["confirmed_tracks"], t["false_tracks"], t["dragged_tracks"]) == (1, 0, 0)
    (car,) = t["targets"]
    assert car["range_m"] == R0 and car["first_held_cycle"] == 2       # confirmed at its third hit (3 of 5)
    assert (car["held_cycles"], car["coasted_cycles"], car["lost_cycles"]) == (80 - 2 - 20, 20, 0)
    assert t["attack_start_cycle"] == 30 and t["dt_s"] == scene_of(SCENE).t_cycle_s
    assert t["first_alarm"]["carav"] == {"cycle": 30, "cycles": 0, "ms": 0.0} and t["first_alarm"]["nis"] is None


def test_a_refusal_longer_than_the_coast_limit_deletes_the_track_and_a_new_one_starts_after():
    refused = set(range(30, 51))                               # 21 cycles
    block = Tracker(**PARAMS)
    block.start()
    sent = _feed(block, _arrivals(_source_frames(80, refused), 0))
    assert _column(sent, "deleted")[50] == [0] and _column(sent, "track_id")[50] == []
    assert _column(sent, "born")[51] == [1] and _column(sent, "status")[55] == ["confirmed"]
    (car,) = block.summary()["run"]["tracks"]["targets"]
    assert car["deleted_tracks"] == 1 and car["track_ids"] == [0, 1]
    assert (car["coasted_cycles"], car["lost_cycles"]) == (20, 1 + 2)    # cycle 50, then 51-52 before confirmation


def test_a_cycle_that_never_comes_is_lost_once_a_later_one_is_far_enough_ahead():
    frames = _source_frames(64, set())
    block = Tracker(**{**PARAMS, "max_hold_cycles": 16})
    block.start()
    order = [("estimates", est) for seq, (est, _) in enumerate(frames) if seq != 1]    # frame 1 lost on the way
    sent = _feed(block, order)
    assert _column(sent, "cycle_index") == list(range(64))
    reasons = _column(sent, "reason")
    assert [c for c in range(64) if reasons[c] == "lost"] == list(range(8, 16))
    assert _column(sent, "track_id")[20] == [0]               # coasted through, not dropped
    late = block.process(frames[1][0], None)             # the lost frame after its turn: counted, left out
    assert late is None and block.summary()["late"] == BATCH


def test_frames_the_estimator_refused_are_unmeasured():
    frame = wire(Frame.of(None, cycle=0, cycles=2, refused=True, reason="no clean verdict",
                          per_cycle={"cycle_index": [0, 1]}), 0)
    block = Tracker(**PARAMS)
    block.start()
    sent = _feed(block, [("estimates", frame)])
    assert _column(sent, "measured") == [False, False]
    assert _column(sent, "reason") == ["refused_by_estimator"] * 2 and _column(sent, "born") == [[], []]


def test_the_nis_alarm_column_when_asked_for():
    block = Tracker(**{**PARAMS, "nis_pfa": 1e-3, "nis_window": 4})
    block.start()
    sent = _feed(block, _arrivals(_source_frames(40, set()), 0))
    alarms = _column(sent, "nis_alarm")
    assert all(a == [False] for a in alarms) and len(alarms) == 40


def test_validation_warns_of_a_target_whose_frozen_range_contradicts_its_doppler():
    warned = Tracker(**{**PARAMS, "scene": "table1"}).param_warnings()
    assert len(warned) == 1 and "-1.111 m/s" in warned[0] and "range" in warned[0]
    assert Tracker(**PARAMS).param_warnings() == []
    assert scene_of(SCENE).range_rate_mps(scene_of(SCENE).targets[0]) == 0.0


@pytest.mark.parametrize("kw, culprit", [({"confirm_m": 6}, "confirm_m"), ({"sigma_range_m": 0.0}, "sigma_range_m")])
def test_a_bad_parameter_is_refused_by_name(kw, culprit):
    with pytest.raises(ValueError, match=culprit):
        Tracker(**{**PARAMS, **kw})
