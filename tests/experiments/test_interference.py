"""`carav experiment interference`: another car's radar in the scene; the detectors' alarms are false alarms."""
from __future__ import annotations

import json

import pytest

from carav_stream.cli import main as carav
from carav_stream.experiments.interference import simulate


def _run(argv):
    return carav(["experiment", "interference", *argv])


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
    a, b = (simulate(10, [1.0], [0.5], 60.0, 1.37, seed=4) for _ in range(2))
    assert a == b and len(a["cells"]) == len(a["random"]) == 1
    f = tmp_path / "a.json"
    assert _run(["--trials", "10", "--rarms", "1", "--slopes", "0.5", "--seed", "4", "--json", str(f)]) == 0
    assert json.loads(f.read_text()) == a                                   # --json writes what simulate returns


def test_the_engine_reports_its_progress_in_cycles_up_to_the_whole():
    seen = []
    simulate(4, [1.0, 3.0], [0.5], 60.0, 1.37, seed=4, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(4, 16), (8, 16), (12, 16), (16, 16)]     # per RARMS: the random attacker, then each slope
