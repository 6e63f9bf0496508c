"""Run summary on an antenna array: the first target's azimuth error against the scene's, with the RMS of the bound
the estimator reported, printed beside range and velocity as covering that one target; no azimuth figures without
an array."""
import math

import pytest

from carav_blocks.run_summary import RunSummary
from carav_stream.cli.run import _radar_lines
from carav_stream.runtime import Frame
from tests.blocks.helpers import SCENE, wire


def test_the_first_targets_azimuth_error_is_scored_against_the_scene():
    s = RunSummary(scene="awr1642_mimo")        # the car at 20 m and 20 degrees
    s.start()
    per = {"cycle_index": [0, 1, 2], "attack_active": [False, False, False],
           "range_m": [[20.0, 35.0], [20.1, None], [None, None]],
           "azimuth_deg": [[20.002, -40.0], [19.996, None], [None, None]],
           "azimuth_std_deg": [[0.0015, 0.01], [0.0013, None], [None, None]]}
    s.process(wire(Frame.of(None, cycles=3, per_cycle=per), 0), None)
    run = s.summary()["run"]
    az = run["azimuth_error_deg"]
    assert az["n"] == 2 and az["true_azimuth_deg"] == 20.0 and az["covers"] == "the scene's first target only"
    assert az["rmse"] == pytest.approx(math.sqrt((0.002 ** 2 + 0.004 ** 2) / 2))
    assert az["mean"] == pytest.approx(-0.001) and az["abs_max"] == pytest.approx(0.004)
    assert az["bound_rms_deg"] == pytest.approx(math.sqrt((0.0015 ** 2 + 0.0013 ** 2) / 2))
    line = [x for x in _radar_lines(run) if "azimuth" in x]
    assert line == ["  azimuth error, first target only (at 20 deg): RMSE 3.16 mdeg, mean -1 mdeg, absolute maximum "
                    "4 mdeg over 2 cycles; its Cramer-Rao std 1.4 mdeg (RMS)"]


def test_a_one_antenna_scene_has_no_azimuth_figures():
    s = RunSummary(scene=SCENE)
    s.start()
    s.process(wire(Frame.of(None, cycles=1, per_cycle={"cycle_index": [0], "range_m": [[43.0]]}), 0), None)
    run = s.summary()["run"]
    assert run["azimuth_error_deg"] is None and not [x for x in _radar_lines(run) if "azimuth" in x]
