"""`carav experiment receivers`: C on 1, 2, 4 and 8 receivers against weak attacks, closed form beside Monte Carlo."""
from __future__ import annotations

import json

import pytest

from carav_stream.cli import main as carav
from carav_stream.experiments.receivers import RECEIVERS, receivers


@pytest.mark.slow
def test_more_receivers_lower_the_threshold_and_the_misses_and_the_json_is_what_the_engine_returns(tmp_path, capsys):
    ticks = []
    out = receivers(40, 3, rarms=(0.5,), progress=lambda done, total: ticks.append((done, total)))
    rows = out["rows"]
    assert [r["n_rx"] for r in rows] == list(RECEIVERS) and ticks[-1] == (40 * 8, 40 * 8)
    etas = [r["eta"] for r in rows]
    assert etas == sorted(etas, reverse=True) and etas[0] == pytest.approx(1.2524, abs=1e-4)
    assert rows[0]["closed_form"] == rows[0]["independent"]                  # one receiver: the same law
    assert rows[0]["closed_form"] > 0.5 > 0.01 > rows[2]["closed_form"]
    assert rows[0]["random"]["missed"] > 20 and rows[3]["random"]["missed"] == rows[3]["smart"]["missed"] == 0
    f = tmp_path / "r.json"
    assert carav(["experiment", "receivers", "--trials", "40", "--rarms", "0.5", "--seed", "3", "--quiet",
                  "--json", str(f)]) == 0
    assert json.loads(f.read_text()) == out
    text = capsys.readouterr().out
    assert "one attacker at broadside" in text and text.count("\n") == 2 + len(RECEIVERS)
