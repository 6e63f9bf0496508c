"""Secondary-antenna experiment (paper V.G): run end to end on a few cycles, check the physics it reports."""
import json

import numpy as np
import pytest

from carav_stream.cli import main as carav
from carav_stream.experiments import secondary_antenna as exp
from carav_stream.experiments.errors import ExperimentError


@pytest.mark.parametrize("attacker", ["ghost", "secondary_antenna"])
def test_high_power_attacks_are_all_detected_and_low_power_ones_all_missed(tmp_path, attacker):
    assert carav(["experiment", "secondary-antenna", "--trials", "8", "--json", str(tmp_path / "out.json"),
                  "--attacker", attacker, "--power", "all"]) == 0
    out = json.loads((tmp_path / "out.json").read_text())
    by_power = {lv["power"]: lv for lv in out["levels"]}
    assert set(by_power) == {"low", "medium", "high"}
    assert by_power["high"]["pm"] == 0.0 and by_power["high"]["n_missed"] == 0
    assert by_power["low"]["pm"] == 1.0
    # a missed low-power attack leaves the car's range within one resolution cell
    assert by_power["low"]["max_missed_range_error_m"] < 1.0
    assert out["clean"]["pf"] == 0.0
    assert len(by_power["low"]["q"]) == 8


def test_secondary_antenna_power_matches_requested_rarms():
    from carav_stream.radar.scene_loader import load_scene
    scene = load_scene("table1")
    att, p_w = exp._make_attacker("secondary_antenna", scene, 1.05, antenna_range_m=30.0, ghost_range_m=45.0)
    assert att.equivalent_rarms() == pytest.approx(1.05, rel=1e-9)
    assert p_w > 0


def test_summary_flags_a_harmful_miss(tmp_path):
    res = {"attacker": "ghost", "power": "medium", "rarms": 1.0, "tx_power_w": None,
           "q": np.array([1.2, 1.3, 2.0]), "range_error_m": np.array([0.1, 2.5, 9.0]),
           "far_rel": np.array([0.0, 0.0, 0.5])}
    s = exp._summary(res, np.array([1.0, 1.1]), 1.5, 1.0, 0.01)
    assert s["n_missed"] == 2 and s["max_missed_range_error_m"] == 2.5
    assert s["harmless_range"] is False and s["pm"] == pytest.approx(2 / 3)


def test_bad_trial_count_is_named():
    with pytest.raises(ExperimentError, match="trials must be >= 1, got 0"):
        exp.experiment(power="all", trials=0, attacker="both", eta=2.0, method="music", antenna_range_m=30.0,
                       ghost_range_m=45.0, snr_db=None, seed=7)
