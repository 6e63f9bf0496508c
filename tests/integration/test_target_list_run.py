"""The radar's target list in a running graph: the demo graph with a CA-CFAR list lists the Table I car in every
clean cycle and few false targets, and the summary scores it."""
import json

import pytest

from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration


def test_the_demo_graph_with_a_cfar_list_reports_the_car_in_every_clean_cycle(carav):
    out = carav.workdir / "s.json"
    done = carav.cli("run", str(ROOT / "graphs" / "demo.toml"), "--cycles", "64", "--set", "ranging.detection=ca_cfar",
                     "--no-progress", "--json", str(out))
    assert done.returncode == 0, done.stderr
    listing = json.loads(out.read_text())["target_list"]
    clean = listing["clean"]
    assert listing["detection"] == "ca_cfar" and clean["cycles"] == 64
    assert clean["targets"][0]["probability_of_detection"] == 1.0
    assert clean["false_targets_per_cycle"] <= 0.2


@pytest.mark.parametrize("max_speed", ["100", "0"])
def test_the_awr1642_car_is_listed_in_every_clean_cycle_only_with_its_range_walk_compensated(carav, max_speed):
    """graphs/awr1642_smart.toml compensates range migration (ranging.max_speed_mps = 100): the car closing at
    83 m/s is listed in every clean cycle at its true range and unaliased velocity; with the compensation off it
    is missed in most cycles and its walk is listed as several false targets (DETECTION.md)."""
    out = carav.workdir / "s.json"
    done = carav.cli("run", str(ROOT / "graphs" / "awr1642_smart.toml"), "--cycles", "48", "--set",
                     "ranging.detection=os_cfar", "--set", f"ranging.max_speed_mps={max_speed}", "--no-progress",
                     "--json", str(out))
    assert done.returncode == 0, done.stderr
    s = json.loads(out.read_text())
    clean = s["target_list"]["clean"]
    pd, false = clean["targets"][0]["probability_of_detection"], clean["false_targets_per_cycle"]
    if max_speed == "100":
        assert pd == 1.0 and false <= 0.1
        assert s["range_error_m"]["rmse"] < 0.02 and s["velocity_error_mps"]["rmse"] < 0.05   # unaliased
    else:
        assert pd < 0.8 and false > 2 and s["velocity_error_mps"]["rmse"] > 80              # the alias
