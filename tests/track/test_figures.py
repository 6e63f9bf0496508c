"""A run's tracks against the truth (track/figures.py): each figure on a hand-made history whose answer is counted
by hand, the gates at their edges, and the alarms' delays from the attack's start."""
import numpy as np
import pytest

from carav_stream.track import NEAR_M, NEAR_MPS, TrackFigures

TRUTH = (np.array([43.0, 80.0]), np.array([0.0, -2.0]))
DT = 5e-4


def _add(f: TrackFigures, cycle: int, tracks: list[tuple[int, str, float, float]], deleted=(), **kw) -> None:
    ids = np.array([t[0] for t in tracks], np.int64)
    f.add(cycle, ids, tuple(t[1] for t in tracks), np.array([t[2] for t in tracks], float),
          np.array([t[3] for t in tracks], float), tuple(deleted), TRUTH, **kw)


def test_a_track_held_coasted_lost_and_deleted_on_its_target_is_counted_cycle_by_cycle():
    f = TrackFigures(2, DT, nis_alarm=False)
    _add(f, 0, [(0, "tentative", 43.0, 0.0)])                            # not confirmed yet: nothing held
    _add(f, 1, [(0, "confirmed", 43.01, 0.0)])                           # held from here
    _add(f, 2, [(0, "confirmed", 43.02, 0.01)])
    _add(f, 3, [(0, "coasting", 43.02, 0.01)])
    _add(f, 4, [(0, "coasting", 43.02, 0.01)])
    _add(f, 5, [], deleted=[0])                                          # deleted while on it
    _add(f, 6, [(1, "tentative", 43.0, 0.0)])
    _add(f, 7, [(1, "confirmed", 43.0, 0.0)])
    t = f.figures(TRUTH)
    car, far = t["targets"]
    assert (car["first_held_cycle"], car["held_cycles"], car["coasted_cycles"], car["lost_cycles"]) == (1, 3, 2, 2)
    assert car["deleted_tracks"] == 1 and car["track_ids"] == [0, 1]
    assert far == {"range_m": 80.0, "velocity_mps": -2.0, "first_held_cycle": None, "held_cycles": 0,
                   "coasted_cycles": 0, "lost_cycles": 0, "deleted_tracks": 0, "track_ids": []}
    assert (t["confirmed_tracks"], t["false_tracks"], t["dragged_tracks"]) == (2, 0, 0)
    assert t["first_alarm"] is None and t["attack_start_cycle"] is None


def test_a_ghost_is_a_false_track_and_a_track_pulled_off_its_target_a_dragged_one():
    f = TrackFigures(2, DT, nis_alarm=False)
    _add(f, 0, [(0, "confirmed", 43.0, 0.0), (1, "confirmed", 30.0, 0.0), (2, "tentative", 60.0, 0.0)])
    _add(f, 1, [(0, "confirmed", 43.5, 0.5), (1, "confirmed", 30.0, 0.0), (2, "tentative", 60.0, 0.0)])
    _add(f, 2, [(0, "confirmed", 44.2, 1.2), (1, "coasting", 30.0, 0.0)])      # track 0 off the car now
    _add(f, 3, [(0, "coasting", 45.0, 2.0)], deleted=[1])
    _add(f, 4, [], deleted=[0])                                                 # deleted off target: not the car's
    t = f.figures(TRUTH)
    assert t["confirmed_tracks"] == 2 and t["false_track_ids"] == [0, 1] and t["false_tracks"] == 2
    assert t["dragged_tracks"] == 1                                             # track 0: on the car, then off
    car = t["targets"][0]
    assert (car["held_cycles"], car["coasted_cycles"], car["lost_cycles"], car["deleted_tracks"]) == (2, 0, 3, 0)


@pytest.mark.parametrize("dr, dv, on", [(NEAR_M, NEAR_MPS, True), (-NEAR_M, -NEAR_MPS, True),
                                        (NEAR_M * 1.001, 0.0, False), (0.0, -NEAR_MPS * 1.001, False)])
def test_a_track_is_on_a_target_within_both_gates_edges_included(dr, dv, on):
    f = TrackFigures(2, DT, nis_alarm=False)
    _add(f, 0, [(0, "confirmed", 80.0 + dr, -2.0 + dv)])
    t = f.figures(TRUTH)
    assert t["false_tracks"] == (0 if on else 1) and t["targets"][1]["held_cycles"] == (1 if on else 0)


def test_a_track_within_the_gates_of_two_targets_is_on_both():
    truth = (np.array([43.0, 43.8]), np.array([0.0, 0.0]))
    f = TrackFigures(2, DT, nis_alarm=False)
    f.add(0, np.array([0]), ("confirmed",), np.array([43.5]), np.array([0.0]), (), truth)
    f.add(1, np.array([]), (), np.array([]), np.array([]), (0,), truth)
    a, b = f.figures(truth)["targets"]
    assert (a["held_cycles"], b["held_cycles"]) == (1, 1)          # held by it, each
    assert (a["deleted_tracks"], b["deleted_tracks"]) == (1, 1) and a["track_ids"] == b["track_ids"] == [0]
    assert f.figures(truth)["false_tracks"] == 0


def test_the_first_alarms_count_from_the_attacks_start_and_ignore_what_came_before():
    f = TrackFigures(2, DT, nis_alarm=True)
    track = [(0, "confirmed", 43.0, 0.0)]
    _add(f, 0, track, reason="attack", attack_active=False, nis_alarm=np.array([True]))   # before the attack
    _add(f, 1, track, attack_active=True, nis_alarm=np.array([False]))
    _add(f, 2, track, attack_active=True, nis_alarm=np.array([False]))
    _add(f, 3, track, reason="attack", attack_active=True, nis_alarm=np.array([False]))
    _add(f, 4, track, attack_active=None, nis_alarm=np.array([True]))                     # a lost cycle
    t = f.figures(TRUTH)
    assert t["attack_start_cycle"] == 1
    assert t["first_alarm"] == {"carav": {"cycle": 3, "cycles": 2, "ms": pytest.approx(2 * DT * 1e3)},
                                "nis": {"cycle": 4, "cycles": 3, "ms": pytest.approx(3 * DT * 1e3)}}


def test_without_an_alarm_the_figures_say_none_and_without_the_nis_alarm_off():
    f = TrackFigures(2, DT, nis_alarm=False)
    _add(f, 0, [], attack_active=True, reason="no_verdict")        # a fail-closed refusal is no detector alarm
    assert f.figures(TRUTH)["first_alarm"] == {"carav": None, "nis": "off"}
    f = TrackFigures(2, DT, nis_alarm=True)
    _add(f, 5, [(0, "confirmed", 43.0, 0.0)], attack_active=True, nis_alarm=np.array([False]))
    assert f.figures(TRUTH)["first_alarm"] == {"carav": None, "nis": None}
