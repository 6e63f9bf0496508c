"""`carav experiment tracks`: against the pull-off, CARAV keeps the car in the picture with no false track while the
undefended picture loses it; the NIS alarm raises an alarm and changes no track; the experiment's tracker is the
tracks graph's."""
from pathlib import Path

import pytest

from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from carav_stream.experiments.tracks import DEFENCES, START, TRACKER, cell
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[2]


def test_the_experiments_tracker_is_the_tracks_graphs():
    graph = load_graph(ROOT / "graphs" / "table1_tracks.toml")
    block = graph.block_class("tracker")(**graph.nodes["tracker"].params)
    assert {k: getattr(block, k) for k in TRACKER} == TRACKER


@pytest.mark.slow
def test_against_the_pull_off_carav_keeps_the_car_and_the_nis_alarm_changes_no_track():
    c = cell("pull_off", 3.0, START + 400, seed=3)
    d = c["defences"]
    assert c["attacked_cycles"] == 400 and c["refused_cycles"] == 400 and c["false_refusals"] == 0
    assert d["CARAV"]["false_tracks"] == 0 and d["CARAV"]["car_lost"] == 0.0 and d["CARAV"]["first_alarm_cycles"] == 0
    assert d["CARAV"]["lead_range_rmse_m"] < 0.01 and d["CARAV"]["lead_cycles"] == 400
    assert d["none"]["false_tracks"] > 0 and d["none"]["car_lost"] > 0.3 and d["none"]["first_alarm_cycles"] is None
    assert d["none"]["lead_range_rmse_m"] > 10 * d["CARAV"]["lead_range_rmse_m"]
    for alarmed, plain in (("NIS", "none"), ("both", "CARAV")):   # an alarm only: the same tracks
        assert {k: v for k, v in d[alarmed].items() if k != "first_alarm_cycles"} == \
            {k: v for k, v in d[plain].items() if k != "first_alarm_cycles"}
    assert d["NIS"]["first_alarm_cycles"] is not None and d["both"]["first_alarm_cycles"] == 0
    assert set(d) == set(DEFENCES)


@pytest.mark.parametrize("args, culprit", [(["--models", "ghots"], "--models: ghots"),
                                           (["--cycles", "100"], "--cycles")])
def test_a_bad_option_is_one_line_naming_it(capsys, args, culprit):
    assert carav(["experiment", "tracks", *args]) == Exit.USAGE
    err = capsys.readouterr().err
    assert culprit in err and len(err.strip().splitlines()) <= 2
