"""Run summary: alarms by reason and detector, detections, and estimation errors in constant memory."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_blocks.run_summary import ErrorStats, RunSummary
from carav_stream.cli.run import _radar_lines
from carav_stream.radar.streams import scene_of
from carav_stream.runtime import Frame
from tests.blocks.helpers import SCENE, wire


@settings(max_examples=50)
@given(st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=200), st.integers(0, 200))
def test_streamed_error_figures_equal_numpy_on_the_whole_list(errors, split):
    a, b = ErrorStats(), ErrorStats()
    for i, e in enumerate(errors):
        (a if i < split else b).add(e)
    got, e = a.merged(b).figures(), np.asarray(errors)
    assert got["n"] == e.size and got["abs_max"] == got["max"] == np.max(np.abs(e))
    assert got["mean"] == pytest.approx(e.mean(), rel=1e-9, abs=1e-9)
    assert got["rmse"] == pytest.approx(math.sqrt(np.mean(e ** 2)), rel=1e-9, abs=1e-12)
    assert ErrorStats().figures() == {"n": 0, "mean": None, "rmse": None, "max": None, "abs_max": None}


def test_the_summary_counts_alarms_detections_and_errors_against_the_scene_truth():
    scene = scene_of(SCENE)
    truth = scene.targets[0].range_m
    s = RunSummary(scene=SCENE)
    s.start()
    est = wire(Frame.of(None, cycles=3, per_cycle={"cycle_index": [0, 1, 3], "attack_active": [False, False, True],
                                                   "range_m": [[truth + 0.1], [truth - 0.3], [truth + 2.0]]}), 0)
    per = {"cycle_index": [2, 4], "attack_active": [True, False], "reason": ["attack", "no_verdict"],
           "raised_by": ["D0", None]}
    alarms = wire(Frame.of(None, cycles=2, per_cycle=per), 1)
    s.process(est, None)
    s.process(None, alarms)
    run = s.summary()["run"]
    assert run["cycles_judged"] == 5 and run["attacked_cycles"] == 2 and run["detected"] == 1
    # the clean cycle refused for want of a verdict is no false alarm: refusals are counted apart
    assert run["missed"] == 1 and run["false_alarms"] == 0 and run["alarm_reasons"] == {"attack": 1, "no_verdict": 1}
    assert run["refused"] == {"cycles": 1, "by_reason": {"no_verdict": 1}, "attacked_cycles": 0}
    assert run["detection_rate"] == 0.5 and run["false_alarm_rate"] == 0.0      # over the 2 clean cycles judged
    assert run["raised_by"] == {"D0": 1}
    assert run["range_error_m"]["n"] == 3 and run["range_error_m"]["max"] == pytest.approx(2.0)
    assert run["range_error_m"]["rmse"] == pytest.approx(math.sqrt((0.1 ** 2 + 0.3 ** 2 + 2.0 ** 2) / 3))
    assert run["range_error_attacked_missed_m"]["n"] == 1      # the one attacked cycle that reached ranging


def test_a_crashed_detector_reads_as_refusals_never_as_detections_or_false_alarms():
    s = RunSummary(scene=SCENE)
    s.start()
    per = {"cycle_index": list(range(6)), "attack_active": [False, False, False, True, True, True],
           "reason": ["no_verdict"] * 6}
    s.process(None, wire(Frame.of(None, cycles=6, per_cycle=per), 0))
    run = s.summary()["run"]
    assert run["detected"] == 0 and run["false_alarms"] == 0 and run["missed"] == 0
    assert run["detection_rate"] is None and run["false_alarm_rate"] is None
    assert run["refused"] == {"cycles": 6, "by_reason": {"no_verdict": 6}, "attacked_cycles": 3}


def test_memory_does_not_grow_with_the_cycles_seen():
    s = RunSummary(scene=SCENE)
    s.start()
    truth = scene_of(SCENE).targets[0].range_m
    frame = wire(Frame.of(None, cycles=64, per_cycle={"attack_active": [False] * 64,
                                                      "range_m": [[truth]] * 64}), 0)
    for _ in range(50):
        s.process(frame, None)
    assert s.summary()["run"]["range_error_m"]["n"] == 3200
    assert all(isinstance(v, ErrorStats) for v in s.range_err.values())   # figures, not lists of errors


def test_a_target_beyond_the_unambiguous_velocity_reports_its_true_error_and_says_it_is_ambiguous():
    scene = scene_of("awr1642")
    true_v, v_max = scene.range_rate_mps(scene.targets[0]), scene.max_velocity_mps
    assert abs(true_v) > v_max                                   # Table II's head-on car: -83 m/s against +-6 m/s
    alias = (true_v + v_max) % (2 * v_max) - v_max               # what a perfect Doppler FFT reports
    s = RunSummary(scene="awr1642")
    s.start()
    s.process(wire(Frame.of(None, cycles=2, per_cycle={"attack_active": [False, False],
                                                       "range_m": [[20.0], [20.0]],
                                                       "velocity_mps": [[alias + 0.1], [alias - 0.1]]}), 0), None)
    run = s.summary()["run"]
    assert run["velocity_ambiguous"] is True and run["unambiguous_velocity_mps"] == pytest.approx(v_max)
    assert run["velocity_error_mps"]["rmse"] == pytest.approx(math.sqrt((alias - true_v) ** 2 + 0.01), rel=1e-6)
    assert run["velocity_error_mps"]["rmse"] > 70                # not hidden by folding
    assert run["velocity_error_modulo_ambiguity_mps"]["rmse"] == pytest.approx(0.1, abs=1e-9)


def test_a_target_within_the_unambiguous_velocity_is_not_flagged():
    scene = scene_of(SCENE)
    s = RunSummary(scene=SCENE)
    s.start()
    true_v = scene.range_rate_mps(scene.targets[0])
    s.process(wire(Frame.of(None, cycles=1, per_cycle={"attack_active": [False], "range_m": [[1.0]],
                                                       "velocity_mps": [[true_v + 0.5]]}), 0), None)
    run = s.summary()["run"]
    assert run["velocity_ambiguous"] is False and run["velocity_error_mps"]["max"] == pytest.approx(0.5)


def test_a_cfar_list_is_scored_per_true_target_with_false_targets_counted_apart():
    scene = scene_of(SCENE)
    r0, v0 = scene.targets[0].range_m, scene.range_rate_mps(scene.targets[0])
    s = RunSummary(scene=SCENE)
    s.start()
    per = {"cycle_index": [0, 1, 2, 3], "attack_active": [False, False, False, True],
           "range_m": [[r0 + 0.05], [r0 + 0.05, 90.0], [], [r0, 25.0]],
           "velocity_mps": [[v0], [v0 + 20.0, 3.0], [], [v0, -10.0]]}   # cycle 1: the car's Doppler is off
    s.process(wire(Frame.of(None, cycles=4, detection="ca_cfar", per_cycle=per), 0), None)
    listing = s.summary()["run"]["target_list"]
    assert listing["detection"] == "ca_cfar"
    assert listing["clean"]["cycles"] == 3 and listing["clean"]["false_targets"] == 2
    assert listing["clean"]["targets"][0]["detected_cycles"] == 1
    assert listing["clean"]["targets"][0]["probability_of_detection"] == pytest.approx(1 / 3)
    ghost = listing["attacked_missed"]                                   # the ghost at 25 m of a missed attack
    assert ghost["cycles"] == 1 and ghost["false_targets"] == 1 and ghost["targets"][0]["detected_cycles"] == 1


def test_a_restarted_summary_says_which_cycles_its_figures_cover_and_carav_run_prints_it():
    first = RunSummary(scene=SCENE)
    first.start()
    assert first.summary()["run"]["figures_cover"] is None          # the run's own: the whole run
    s = RunSummary(scene=SCENE)
    s.instance = (2, 0)                                               # the node's third process
    s.start()
    for seq, cycles in enumerate(([1088, 1089], [1090, 5312])):
        s.process(wire(Frame.of(None, cycles=2, per_cycle={"cycle_index": cycles, "attack_active": [False] * 2}),
                       seq), None)
    run = s.summary()["run"]
    assert run["figures_cover"]["text"] == ("figures cover cycles 1088-5312 only (4 cycles counted): run_summary "
                                            "restarted 2 times")
    assert any(line.strip() == run["figures_cover"]["text"] for line in _radar_lines(run))


@pytest.mark.parametrize("unfolded", [False, True])
def test_the_printed_summary_says_whether_a_fast_targets_velocity_was_unfolded_or_aliased(unfolded):
    # awr1642's head-on car: a Doppler FFT alone reports the alias; an estimator following the range walk
    # (range_estimator's max_speed_mps) reports the true velocity, and the summary must not call that aliased
    scene = scene_of("awr1642")
    true_v, v_max = scene.range_rate_mps(scene.targets[0]), scene.max_velocity_mps
    reported = true_v if unfolded else (true_v + v_max) % (2 * v_max) - v_max
    s = RunSummary(scene="awr1642")
    s.start()
    s.process(wire(Frame.of(None, cycles=2, per_cycle={"attack_active": [False, False],
                                                       "range_m": [[20.0], [20.0]],
                                                       "velocity_mps": [[reported + 0.1], [reported - 0.1]]}), 0),
              None)
    text = "\n".join(_radar_lines({**s.summary()["run"], "cycles": 2}))
    assert ("the estimates were unfolded" in text) is unfolded
    assert ("the error above is the aliased estimate's" in text) is not unfolded
