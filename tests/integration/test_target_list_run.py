"""The radar's target list in a running graph: the demo graph with a CA-CFAR list lists the Table I car in every
clean cycle and few false targets, and the summary scores it."""
import json

import pytest

from tests.integration.conftest import ROOT

pytestmark = pytest.mark.integration


def test_the_demo_graph_with_a_cfar_list_reports_the_car_in_every_clean_cycle(carav):
    out = carav.workdir / "s.json"
    done = carav.cli("run", str(ROOT / "graphs" / "demo.toml"), "--cycles", "64", "--set", "ranging.detection=ca_cfar",
                     "--no-progress", "--json", str(out), timeout_s=120)
    assert done.returncode == 0, done.stderr
    listing = json.loads(out.read_text())["target_list"]
    clean = listing["clean"]
    assert listing["detection"] == "ca_cfar" and clean["cycles"] == 64
    assert clean["targets"][0]["probability_of_detection"] == 1.0
    assert clean["false_targets_per_cycle"] <= 0.2
