"""`carav experiment interference`: another car's radar in the scene; the detectors' alarms are false alarms."""
from __future__ import annotations

import argparse
import json

import pytest

from carav_stream.experiments import interference


def _run(argv):
    parser = argparse.ArgumentParser()
    interference.configure(parser)
    return interference.run(parser.parse_args(argv))


@pytest.mark.slow
def test_a_matched_interferer_is_flagged_like_an_attack_and_a_faint_one_is_not(tmp_path, capsys):
    out = tmp_path / "i.json"
    assert _run(["--trials", "40", "--rarms", "0.05,0.3,3", "--slopes", "1", "--seed", "2", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    cell = {c["rarms"]: c for c in res["cells"]}
    rnd = {a["rarms"]: a for a in res["random"]}
    # strong: every energy detector fires on a benign radar exactly as on the random attacker
    assert cell[3.0]["c_1_5"] == 40 and rnd[3.0]["c_1_5"] == 40
    # faint (RARMS 0.05): below every energy threshold
    assert cell[0.05]["c_1_5"] == cell[0.05]["c_design"] == 0
    # RARMS 0.3: a matched radar is a tone in the silent chirps, which the spectral test sees and a noise-like
    # attacker of the same power is not (C sees neither)
    assert cell[0.3]["spectral"] == 40 and rnd[0.3]["spectral"] == 0 and cell[0.3]["c_1_5"] == 0
    text = capsys.readouterr().out
    assert "interferer, slope x1" in text and "every alarm is false" in text


def test_results_are_reproducible_for_a_seed(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    for f in (a, b):
        _run(["--trials", "10", "--rarms", "1", "--slopes", "0.5", "--seed", "4", "--json", str(f)])
    assert json.loads(a.read_text()) == json.loads(b.read_text())
