"""`carav run`'s printed summary: rounded figures with units, n/a for nothing measured, the real-time factor from
the scene's cycle duration, refusals apart from the detector's verdicts; the JSON keeps every figure unrounded."""
import json

import pytest

from carav_blocks.run_summary import RunSummary
from carav_stream.cli.run import print_summary, with_radar_time
from carav_stream.radar.streams import scene_of
from carav_stream.runtime import Frame
from tests.blocks.helpers import SCENE, wire


def runtime(cycles: int, wall_s: float) -> dict:
    """The supervisor's own keys of a summary (runtime/report.py), for a graph of one summary node."""
    return {"graph": "g.toml", "run": "g-1", "host": "local", "cycles": cycles, "lost": 0, "lost_by_edge": {},
            "estimated_counts": [], "rejected": 0, "unpaired": 0, "restarts": 0, "failures": [], "swaps": [],
            "stopped_by": "end of stream", "wall_s": wall_s, "throughput_cycles_per_s": cycles / wall_s,
            "per_node": {"summary": {"block": "run_summary", "in": {"alarms": 2}, "out": {}, "rejected": {},
                                     "restarts": 0}}}


def summarised(per_cycle: dict, cycles: int, wall_s: float) -> dict:
    s = RunSummary(scene=SCENE)
    s.start()
    s.process(None, wire(Frame.of(None, cycles=cycles, per_cycle=per_cycle), 0))
    return with_radar_time({**runtime(cycles, wall_s), **s.summary()["run"]})


def test_a_crashed_detector_prints_refusals_apart_and_no_rate_it_did_not_measure(capsys):
    # 6 cycles refused for want of a verdict (the detector died), 2 attacked cycles judged and detected
    per = {"cycle_index": list(range(8)), "attack_active": [False] * 3 + [True] * 5,
           "reason": ["no_verdict"] * 6 + ["attack"] * 2}
    s = summarised(per, 8, 0.5)
    print_summary(s)
    out = capsys.readouterr().out
    assert "None" not in out
    assert "attacked cycles 5, 2 judged by the detector: detected 2, missed 0 (detection rate 100 %)" in out
    assert "false alarms 0 on 0 clean cycles judged (false-alarm rate n/a)" in out
    assert "refused without a verdict (fail closed): 6 cycles (no_verdict 6; 3 of them attacked)" in out
    assert "range error, first target: n/a (no estimate)" in out
    assert "frames in" in out and "frames out" in out      # per-node counts are frames, and say so


def test_the_real_time_factor_is_the_radar_time_of_the_cycles_over_the_wall_time(capsys):
    t_cycle = scene_of(SCENE).t_cycle_s
    n, wall = 3000, 2.5
    per = {"cycle_index": list(range(n)), "attack_active": [True] * n, "reason": ["attack"] * n}
    s = summarised(per, n, wall)
    assert s["radar_cycle_duration_s"] == t_cycle and s["radar_time_s"] == pytest.approx(n * t_cycle, rel=1e-12)
    assert s["real_time_factor"] == pytest.approx(n * t_cycle / wall, rel=1e-12)
    assert s["real_time_factor"] == pytest.approx(s["throughput_cycles_per_s"] / s["radar_cycles_per_s"], rel=1e-12)
    print_summary(s)
    out = capsys.readouterr().out
    assert f"{n} cycles in 2.5 s of wall time: 1200 cycles/s" in out
    factor = f"{n * t_cycle / wall:.3g}"
    assert (f"real-time factor {factor} (radar time / wall time): radar time {n * t_cycle:.3g} s = {n} cycles x "
            f"the scene's cycle duration {t_cycle * 1e6:.3g} us") in out
    assert json.loads(json.dumps(s))["real_time_factor"] == s["real_time_factor"]   # unrounded in the JSON


def test_errors_print_with_units_and_the_absolute_maximum_by_name(capsys):
    truth = scene_of(SCENE).targets[0].range_m
    per = {"cycle_index": [0, 1], "attack_active": [False, False], "verdict": ["clean", "clean"],
           "range_m": [[truth + 0.002], [truth - 0.004]], "velocity_mps": [[None], [None]]}
    s = RunSummary(scene=SCENE)
    s.start()
    s.process(wire(Frame.of(None, cycles=2, per_cycle=per), 0), None)
    summary = with_radar_time({**runtime(2, 0.01), **s.summary()["run"]})
    assert summary["range_error_m"]["abs_max"] == pytest.approx(0.004, rel=1e-6)
    print_summary(summary)
    out = capsys.readouterr().out
    assert "range error, first target: RMSE 3.16 mm, mean -1 mm, absolute maximum 4 mm over 2 cycles" in out
    assert "velocity error, first target: n/a (no estimate)" in out and "None" not in out


def test_a_graph_without_a_run_summary_prints_no_real_time_factor(capsys):
    s = with_radar_time(runtime(400, 0.2))
    assert "real_time_factor" not in s
    print_summary(s)
    out = capsys.readouterr().out
    assert "400 cycles in 200 ms of wall time: 2000 cycles/s" in out and "real-time factor" not in out


def test_whole_run_figures_print_no_coverage_line_and_a_restarted_summary_says_what_it_covers(capsys):
    per = {"cycle_index": [5, 6, 7], "attack_active": [False] * 3}
    print_summary(summarised(per, 3, 0.5))
    assert "figures cover" not in capsys.readouterr().out      # the whole run: nothing to warn about
    restarted = RunSummary(scene=SCENE)
    restarted.instance = (1, 0)                                 # the run_summary's first restart
    restarted.start()
    restarted.process(None, wire(Frame.of(None, cycles=3, per_cycle=per), 0))
    print_summary(with_radar_time({**runtime(3, 0.5), **restarted.summary()["run"]}))
    lines = [line for line in capsys.readouterr().out.splitlines() if "figures cover" in line]
    assert lines == ["  figures cover cycles 5-7 only (3 cycles counted): run_summary restarted 1 time"]


def test_the_trackers_figures_print_as_tracks_targets_and_first_alarms(capsys):
    from carav_blocks.tracker import Tracker
    from tests.blocks.test_tracker import PARAMS, _arrivals, _feed, _source_frames
    block = Tracker(**{**PARAMS, "nis_pfa": 1e-3, "nis_window": 4})
    block.start()
    _feed(block, _arrivals(_source_frames(80, set(range(30, 51))), 0))      # one cycle past the coast limit
    s = {**runtime(80, 1.0), **block.summary()["run"]}
    print_summary(s)
    out = capsys.readouterr().out
    assert ("  tracks: 80 cycles tracked, 21 unmeasured (attack 21); 2 confirmed, 0 false (off every target by "
            "more than 1 m or 1 m/s while confirmed), 0 of them dragged off a target\n") in out
    assert ("    target at 43 m, 0 m/s: held from cycle 2: updated 55 cycles, coasted 20, lost 3; its tracks deleted "
            "1\n" in out)
    assert "    first alarm from the attack's start (cycle 30): CARAV after 0 cycles (0 ms), NIS alarm none\n" in out
    assert "tracks: {" not in out                   # printed as the tracker's lines, not as an unknown key
    assert json.loads(json.dumps(s))["tracks"]["targets"][0]["lost_cycles"] == 3
